#pragma once
// Private to locate: the area centroid of a disc's projected image and its
// derivatives (pose.h, "project_disc_centroid"), shared by the public
// helper and the Ceres cost functions of pose.cpp and pinhole_pose.cpp.

#include <cstddef>
#include <vector>

#include "tactres/camera/camera_model.h"
#include "tactres/targets/geometry.h"

namespace tactres::locate_detail {

// Workspace and core of the projected-disc centroid.
//
// The disc's boundary is sampled at `n` points, transformed into the camera
// (J_rt from mrcal_transform_point_rt) and projected (dq/dp and optionally
// dq/dintrinsics from mrcal_project). The centroid of the projected polygon
// uses the shoelace formulas
//   2A = sum c_i,  c_i = x_i y_{i+1} - x_{i+1} y_i,
//   Cx = sum (x_i + x_{i+1}) c_i / (3 * 2A),  Cy likewise with y,
// evaluated relative to the first vertex: the centroid is translation
// equivariant, so the derivatives are unchanged and the sums do not cancel
// catastrophically at pixel coordinates in the hundreds.
class DiscCentroidEvaluator {
 public:
  // The disc (center_mm, radius_mm) on the target face as a polygon of n
  // boundary points.
  DiscCentroidEvaluator(const CameraModel& camera, Vec2 center_mm, double radius_mm, int n);

  // centroid; dC_drt (2x6 row-major) and dC_dintrinsics (2 x Ni row-major)
  // are filled if not null. Returns false if any vertex cannot be projected or
  // the polygon is degenerate.
  bool evaluate(const double* rt, Vec2* centroid, double* dC_drt, double* dC_dintrinsics);

 private:
  // Shoelace centroid of the polygon through every `stride`-th projected
  // vertex. If `want_gradient`, adds weight * dC/dq_k into dC_dq_ (cleared
  // first if `clear`).
  bool polygon_centroid(std::size_t stride, Vec2* centroid, bool want_gradient, double weight,
                        bool clear);

  const CameraModel& camera_;
  std::size_t n_;
  std::vector<Vec3> target_;
  std::vector<Vec3> p_;
  std::vector<double> J_rt_;
  std::vector<Vec2> q_;
  std::vector<double> dq_dp_;
  std::vector<double> dq_di_;
  std::vector<double> dC_dq_;
};

}  // namespace tactres::locate_detail
