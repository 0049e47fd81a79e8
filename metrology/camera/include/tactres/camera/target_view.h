#pragma once
// TargetView: where the target plane lands in the image, through the pose
// camera_from_target and the lens model (mrcal). The only projection code
// in tactres goes through CameraModel; nothing here models distortion.
//
// Target points are (x, y, 0) in mm in the target frame (docs/CONVENTIONS.md).

#include <array>
#include <optional>
#include <span>
#include <vector>

#include "tactres/camera/camera_model.h"
#include "tactres/camera/plane_map.h"
#include "tactres/targets/geometry.h"

namespace tactres {

class TargetView final : public PlaneToImage {
 public:
  // rt_camera_from_target: mrcal rt convention (Rodrigues r, then t in mm).
  TargetView(const CameraModel& camera, const std::array<double, 6>& rt_camera_from_target);

  const CameraModel& camera() const { return camera_; }
  const std::array<double, 6>& rt() const { return rt_; }

  Vec3 to_camera(Vec2 target_mm) const;
  // Pixel of a target point; nullopt if behind the camera or not projectable.
  std::optional<Vec2> project(Vec2 target_mm) const override;
  // Pixel and the 2x2 Jacobian d(px)/d(target mm), row-major.
  std::optional<std::pair<Vec2, std::array<double, 4>>> project_with_jacobian(Vec2 target_mm) const;

  // Target point seen at each pixel (ray / plane intersection); nullopt where
  // the ray misses the plane (parallel or behind).
  std::vector<std::optional<Vec2>> target_from_pixels(std::span<const Vec2> px) const;

  // Image scale at a target point across bars of the given orientation
  // (along target x for vertical bars, along y for horizontal bars), in
  // pixels per mm; 0 if not projectable.
  double px_per_mm_across(Vec2 target_mm, BarOrientation bars) const override;
  // The camera's sampling limit at a target point for bars resolving detail
  // along y (horizontal bars) and along x (vertical bars): 0.5 cycles/px.
  struct Nyquist {
    double horizontal_bars_lp_per_mm = 0, vertical_bars_lp_per_mm = 0;
  };
  Nyquist nyquist(Vec2 target_mm) const;

  // Camera on the +z side of the target: a through-gel (mirrored) view.
  bool seen_from_behind() const;

 private:
  const CameraModel& camera_;
  std::array<double, 6> rt_;
  double R_[9];  // row-major rotation camera_from_target
};

// Pixel -> target map over a whole image, exact on a lattice every
// `step_px` pixels and bilinear in between (the lens map is smooth at that
// scale; the error is tested to stay far below 1e-3 px). Sample positions
// are in pixel coordinates, (0,0) the centre of the top-left pixel.
class InverseMap {
 public:
  InverseMap(const TargetView& view, double x0_px, double y0_px, double x1_px, double y1_px,
             double step_px);
  // Target point at a pixel position; nullopt where the lattice had no
  // intersection.
  std::optional<Vec2> at(double x_px, double y_px) const;

 private:
  double x0_, y0_, step_;
  int nx_, ny_;
  std::vector<Vec2> grid_;
  std::vector<unsigned char> valid_;
};

}  // namespace tactres
