#pragma once
// Measurement of one capture (`tactres measure`): locate the target through
// the camera model, normalise on the reference patch, fit every element's
// profile, grade it, and decide the limits per orientation.
//
// Every failure is data: an unusable capture has usable = false and a
// problem a user can act on; an element that cannot be measured has a
// graded status and is never called resolved. No field is ever NaN.

#include <array>
#include <cmath>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "tactres/camera/camera_model.h"
#include "tactres/profiles/criterion.h"
#include "tactres/locate/fiducials.h"
#include "tactres/camera/image_io.h"
#include "tactres/locate/pose.h"
#include "tactres/profiles/profile_fit.h"
#include "tactres/profiles/profile_sampler.h"
#include "tactres/targets/layout.h"

namespace tactres {

enum class ElementStatus {
  ok,                    // fitted; resolved or not by the criterion
  low_signal,            // the fit cannot pin m down (m_sigma too large)
  clipped,               // saturated or black pixels in the profile
  aliased,               // the data do not show the expected bars (wrong period or count)
  below_sampling_limit,  // too few pixels per bar to measure
  out_of_view,           // the element's strip is not fully inside the image
  fit_failed,            // the solver failed or the fit is degenerate
};
const char* to_string(ElementStatus s);

enum class Preset { fast, balanced, precise };
const char* to_string(Preset p);
Preset preset_from_string(const std::string& s);  // throws std::invalid_argument

struct MeasureOptions {
  Preset preset = Preset::balanced;
  ProfileSamplingOptions sampling;
  bool fit_psf_shape = true;        // fit beta (PSF shape); false: Gaussian
  int pose_boundary_points = 48;    // disc outline points in the pose model
  double max_bins_per_bar = 10;     // coarse elements: bins no finer than w / this
  Criterion criterion;
  double min_px_per_bar = 1.5;      // below: below_sampling_limit
  double aliasing_chi2 = 16;        // reduced chi^2 above which a fine element is aliased
  double max_m_sigma = 0.25;        // above: low_signal
  double max_patch_chi2 = 50;       // above: the capture does not match the layout
  double transfer_check_chi2 = 10;  // patch reduced chi^2 above which other transfer curves are tried
  double poor_fit_chi2 = 25;        // an ok element above this gets a note (its sigma is already widened)
  std::string signature = "auto";   // auto | albedo | shading

  static MeasureOptions for_preset(Preset p);
  void validate() const;  // throws std::invalid_argument
};

struct ElementResult {
  int group = 0, element = 1;
  BarOrientation orientation = BarOrientation::horizontal_bars;
  double lp_per_mm = 0, px_per_bar = 0;
  double m = 0, m_sigma = 0;  // 0 when the status is not ok
  double beta = 0, chi2_reduced = 0;
  ElementStatus status = ElementStatus::fit_failed;
  bool resolved = false;
  std::string note;  // why a graded or poorly fitting element is what it is; empty if nothing to say
  std::array<Vec2, 4> outline_px{};
  bool outline_valid = false;
};

struct ReferenceResult {
  bool usable = false;
  std::string problem;
  Signature signature = Signature::albedo;
  // Contrast scale per profile direction: across x (vertical bars) and
  // across y (horizontal bars), with standard errors.
  double contrast_x = 0, contrast_x_sigma = 0;
  double contrast_y = 0, contrast_y_sigma = 0;
  double chi2_x = 0, chi2_y = 0;  // reduced chi^2 of the patch fits
  bool layout_mismatch = false;   // refused: the model cannot describe the patch where the layout puts it
  // A usable contrast scale across x (vertical bars) or y (horizontal bars):
  // a relief lit along one axis has none across the other.
  bool has_contrast(bool across_x) const {
    const double c = across_x ? contrast_x : contrast_y, s = across_x ? contrast_x_sigma : contrast_y_sigma;
    return std::abs(c) > 5 * s && std::abs(c) > 1e-4;
  }
  std::vector<Vec2> outline_px;   // corners of the two patch strips in the image
};

struct Measurement {
  bool usable = false;
  std::string problem;  // why not usable, and what to do
  int image_width = 0, image_height = 0;
  std::string camera_source;       // the model file, or "pinhole fitted from fiducials"
  bool distortion_corrected = false;
  FiducialSearchResult fiducials;
  PoseResult pose;
  ReferenceResult reference;
  TransferDecision transfer;    // the curve the capture was measured with, and why
  TransferCheck transfer_check; // what the reference patch said about that curve
  std::vector<std::string> warnings;  // for people: what to check although the capture was measured
  std::vector<ElementResult> elements;
  Limit horizontal, vertical;
  double nyquist_h_lp_per_mm = 0, nyquist_v_lp_per_mm = 0;
  std::vector<std::pair<std::string, double>> stage_seconds;
};

// `camera` may be null: a pinhole is then fitted from the fiducials and the
// result says distortion was not corrected. Throws std::invalid_argument for
// a camera model whose imager size differs from the image.
Measurement measure_capture(const LoadedImage& image, const TargetLayout& layout, const CameraModel* camera,
                            const MeasureOptions& options);

}  // namespace tactres
