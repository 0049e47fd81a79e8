#pragma once
// Layout mode of `tactres measure`: locate the target through the camera
// model, normalise on the reference patch, and run every element of the
// layout through the element pipeline (element_pipeline.h), which grades it
// and decides the limits per orientation (types: measurement.h).

#include <functional>
#include <optional>

#include "tactres/camera/camera_model.h"
#include "tactres/camera/image_io.h"
#include "tactres/measure/measurement.h"
#include "tactres/targets/layout.h"

namespace tactres {

// `camera` may be null: a pinhole is then fitted from the fiducials and the
// result says distortion was not corrected. Throws std::invalid_argument for
// a camera model whose imager size differs from the image.
Measurement measure_capture(const LoadedImage& image, const TargetLayout& layout, const CameraModel* camera,
                            const MeasureOptions& options);

// ---------------------------------------------------------------------------
// One frame of a live sequence (live/, docs/LIVE.md): the same measurement,
// with what the frame before established carried over where it still holds.

// What a measured frame established about the scene, for the next frame.
struct LayoutTrack {
  RtCameraFromTarget rt_camera_from_target_mm{};
  std::optional<CameraModel> fitted_camera;  // the pinhole fitted when no model is given
  FiducialSearchResult fiducials;  // the discs as found
  double pose_rms_px = 0;          // of the pose fit on them
  // The reference patch and the pixel decoding it chose (fit_reference).
  ReferenceResult reference;
  TransferDecision transfer;
  TransferCheck transfer_check;
  bool encoding_mismatch = false;
};

struct FramePlan {
  // Null: locate the target in the whole frame. Otherwise each disc is
  // measured where this track saw it (track_fiducials), then, failing that,
  // searched near there (the track's box grown by `search_margin` of its
  // size on every side); the pose starts from the track's. When neither
  // finds the discs the whole frame is searched. A tracked pose that fits
  // far worse than the track's (RMS > 3x and > 0.3 px) is refused: the
  // caller measures the frame from scratch.
  const LayoutTrack* track = nullptr;
  double search_margin = 0.25;
  // With a track: keep its reference patch (the light has not changed)
  // instead of fitting the patch again.
  bool reuse_reference = false;
  // Fit only the layout elements this accepts (index into layout.elements);
  // the others are taken from `carried` (a previous measurement of the
  // same layout, all elements in layout order). Empty: fit every element.
  std::function<bool(size_t)> fit_element;
  const std::vector<ElementResult>* carried = nullptr;
};

struct FrameResult {
  Measurement measurement;
  std::optional<LayoutTrack> track;  // set when the measurement is usable
  bool tracked = false;              // the fiducials were found near the track
  bool reference_refit = false;      // the patch was fitted on this frame
};

// measure_capture with a plan; measure_capture(...) == measure_frame(..., {}).
FrameResult measure_frame(const LoadedImage& image, const TargetLayout& layout, const CameraModel* camera,
                          const MeasureOptions& options, const FramePlan& plan);

}  // namespace tactres
