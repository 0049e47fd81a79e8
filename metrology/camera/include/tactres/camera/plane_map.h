#pragma once
// PlaneToImage: where points of a plane (in mm) land in the image. It is
// what a profile is sampled through (profiles/profile_sampler.h):
// - TargetView (target_view.h): the layout's target plane through a pose
//   and the mrcal lens model (layout mode);
// - PatternFrame (below): one bar pattern of a standard chart, found in the
//   image, in its own plane (chart mode, which has no camera model).
//
// Contract: project() returns nullopt for a point that has no pixel;
// px_per_mm_across() is the image scale across bars of the given
// orientation at a plane point (along plane x for vertical bars, along y
// for horizontal bars), in pixels per mm, 0 where there is no pixel.

#include <optional>

#include "tactres/targets/geometry.h"
#include "tactres/targets/layout.h"

namespace tactres {

class PlaneToImage {
 public:
  virtual ~PlaneToImage() = default;
  virtual std::optional<Vec2> project(Vec2 plane_mm) const = 0;
  virtual double px_per_mm_across(Vec2 plane_mm, BarOrientation bars) const = 0;
};

// A similarity from a pattern's own plane to the image:
//   pixel = center_px + px_per_mm * (x * x_dir + y * perp(x_dir)),
// with |x_dir| = 1. The plane's origin is the pattern's centre. Whether the
// chart is mirrored does not matter within one pattern: its bars are
// symmetric, so a proper rotation always describes them.
struct PatternFrame final : PlaneToImage {
  Vec2 center_px;
  Vec2 x_dir{1, 0};  // image direction of plane x (unit)
  double px_per_mm = 1;

  PatternFrame() = default;
  PatternFrame(Vec2 center, Vec2 x_direction, double scale_px_per_mm)
      : center_px(center), x_dir(x_direction), px_per_mm(scale_px_per_mm) {}

  Vec2 y_dir() const { return {-x_dir.y, x_dir.x}; }
  std::optional<Vec2> project(Vec2 plane_mm) const override {
    return center_px + px_per_mm * (plane_mm.x * x_dir + plane_mm.y * y_dir());
  }
  double px_per_mm_across(Vec2, BarOrientation) const override { return px_per_mm; }
  // The plane point at a pixel (the inverse of project).
  Vec2 to_plane(Vec2 px) const {
    const Vec2 d = px - center_px;
    return (1.0 / px_per_mm) * Vec2{dot(d, x_dir), dot(d, y_dir())};
  }
};

}  // namespace tactres
