#pragma once
// The forward model: renders a scene into the capture a given sensor and
// camera would record. Only the effects listed in the scene run; with none,
// the result is the exact area coverage of the target seen through the lens
// (albedo targets) in float.
//
// Pipeline (each stage only if listed):
//   target plane  albedo coverage, or relief height (contact) -> shading
//                 -> x illumination E(x, y)
//   image plane   supersampled grid -> blur (PSF) -> box down to pixels
//                 -> vignetting -> sensor (noise, quantisation, saturation)
// Pixel values are the average over each pixel's footprint: exact polygon
// coverage of each sub-pixel for albedo targets, sub-pixel point samples of
// the (smooth) relief radiance otherwise.

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "tactres/camera/camera_model.h"
#include "tactres/simulate/scene.h"
#include "tactres/targets/layout.h"

namespace tactres {

struct RenderResult {
  cv::Mat image;  // CV_32F (no sensor effect) or CV_8U / CV_16U in DN
  int bits = 0;   // significant bits of a quantised image, 0 for float
  std::vector<std::pair<std::string, double>> stage_seconds;
};

// `seed` overrides the sensor effect's seed.
RenderResult render_scene(const Scene& scene, const TargetLayout& layout, const CameraModel& camera,
                          std::optional<std::uint64_t> seed = std::nullopt);

// Radiance on the target plane before the optics (shared by the renderer and
// the truth computation), at a point and for a sub-pixel footprint.
class TargetRadiance {
 public:
  TargetRadiance(const Scene& scene, const TargetLayout& layout);
  ~TargetRadiance();
  // `quad` is the sub-pixel footprint in target mm (4 corners, either order).
  double over_footprint(const Vec2 quad[4]) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace tactres
