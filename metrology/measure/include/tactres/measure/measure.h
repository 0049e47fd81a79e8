#pragma once
// Layout mode of `tactres measure`: locate the target through the camera
// model, normalise on the reference patch, and run every element of the
// layout through the element pipeline (element_pipeline.h), which grades it
// and decides the limits per orientation (types: measurement.h).

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

}  // namespace tactres
