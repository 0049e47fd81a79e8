#pragma once
// The reference patch: the contrast scale that turns bar profiles into m(f),
// the signature (printed bars or a relief seen through a gel), and the
// check that the capture's pixel encoding is the one the patch fits.
//
// fit_reference_patch() contract:
// - In: the linear luminance, the target view, the layout, the options.
// - Out: a ReferenceResult; usable = false with a problem a user can act on
//   when the patch is out of view, clipped, shows no contrast, or cannot be
//   described by the profile model (the layout does not match the capture).
//   Never throws for bad data.
//
// check_transfer() contract (docs/CONVENTIONS.md, "Pixels in"):
// - Runs only when the patch fits far worse than its noise model allows
//   (reduced chi^2 above options.transfer_check_chi2) or was refused as not
//   matching the layout. It re-decodes the pixels around the patch with the
//   other standard curve (linear or sRGB) and a small family of power laws,
//   and refits the patch under each.
// - When another curve fits far better (chi^2 at least 4x lower and
//   near its noise), the result names it. If the curve in use was only
//   guessed from the bit depth and the better one is linear or sRGB,
//   `switch_to` is set: the caller re-decodes the capture and measures with
//   it. Otherwise the capture is measured as the user or the file said, and
//   `mismatch` tells the element grading that a global model mismatch, not
//   aliasing, explains poor fits.
// - Costs nothing (no refit) on captures whose patch fits.

#include <optional>
#include <string>

#include <opencv2/core/mat.hpp>

#include "tactres/measure/measurement.h"
#include "tactres/camera/target_view.h"
#include "tactres/camera/transfer_curve.h"
#include "tactres/targets/coverage.h"

namespace tactres {

struct PatchScene {
  const TargetView& view;
  const TargetLayout& layout;
  const IndexedArtwork& artwork;
  double clip_level = 0;     // integer images clip at 1.0; 0 = float, no clip
  bool have_camera = false;  // for the advice in a mismatch message
};

ReferenceResult fit_reference_patch(const cv::Mat& luminance, const PatchScene& scene, const MeasureOptions& options);


TransferCheck check_transfer(const cv::Mat& luminance, const TransferDecision& decision,
                             const ReferenceResult& reference, const PatchScene& scene,
                             const MeasureOptions& options);

// The luminance re-decoded with `to`, given that it was decoded with
// `from`: exact for grey files and for neutral (grey) targets in colour
// files, whose channels carry the same code value. NaN stays NaN.
cv::Mat redecode(const cv::Mat& luminance, const TransferCurve& from, const TransferCurve& to);

}  // namespace tactres
