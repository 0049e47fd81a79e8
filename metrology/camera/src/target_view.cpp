#include "tactres/camera/target_view.h"

#include <cmath>

extern "C" {  // mrcal ships C headers without C++ guards
#include <mrcal/poseutils.h>
}

namespace tactres {

TargetView::TargetView(const CameraModel& camera, const std::array<double, 6>& rt)
    : camera_(camera), rt_(rt) {
  mrcal_R_from_r(R_, nullptr, rt.data());
}

Vec3 TargetView::to_camera(Vec2 p) const {
  return {R_[0] * p.x + R_[1] * p.y + rt_[3], R_[3] * p.x + R_[4] * p.y + rt_[4],
          R_[6] * p.x + R_[7] * p.y + rt_[5]};
}

std::optional<Vec2> TargetView::project(Vec2 target_mm) const {
  const Vec3 c = to_camera(target_mm);
  const auto q = camera_.project(std::span<const Vec3>(&c, 1));
  if (q.empty() || !q[0].valid) return std::nullopt;
  return q[0].px;
}

std::optional<std::pair<Vec2, std::array<double, 4>>> TargetView::project_with_jacobian(
    Vec2 target_mm) const {
  const Vec3 c = to_camera(target_mm);
  const auto q = camera_.project_with_gradient(std::span<const Vec3>(&c, 1));
  if (q.empty() || !q[0].valid) return std::nullopt;
  // d px / d target = d px / d p_cam * d p_cam / d target, and d p_cam /
  // d (x, y) are the first two columns of R.
  const auto& g = q[0].dpx_dpoint;  // row-major 2x3
  std::array<double, 4> J{};
  for (int r = 0; r < 2; ++r)
    for (int c2 = 0; c2 < 2; ++c2)
      J[r * 2 + c2] = g[r * 3 + 0] * R_[0 + c2] + g[r * 3 + 1] * R_[3 + c2] + g[r * 3 + 2] * R_[6 + c2];
  return std::make_pair(q[0].px, J);
}

std::vector<std::optional<Vec2>> TargetView::target_from_pixels(std::span<const Vec2> px) const {
  const auto rays = camera_.unproject(px);
  std::vector<std::optional<Vec2>> out(rays.size());
  // Plane: normal n = R e3 through t. Ray: lambda d from the origin.
  const Vec3 n{R_[2], R_[5], R_[8]};
  const double n_dot_t = n.x * rt_[3] + n.y * rt_[4] + n.z * rt_[5];
  for (size_t i = 0; i < rays.size(); ++i) {
    if (!rays[i]) continue;
    const Vec3& d = *rays[i];
    const double n_dot_d = n.x * d.x + n.y * d.y + n.z * d.z;
    if (std::abs(n_dot_d) < 1e-12) continue;
    const double lambda = n_dot_t / n_dot_d;
    if (!(lambda > 0)) continue;
    const Vec3 p{lambda * d.x - rt_[3], lambda * d.y - rt_[4], lambda * d.z - rt_[5]};
    // target = R^T (P - t)
    out[i] = Vec2{R_[0] * p.x + R_[3] * p.y + R_[6] * p.z, R_[1] * p.x + R_[4] * p.y + R_[7] * p.z};
  }
  return out;
}

double TargetView::px_per_mm_across(Vec2 target_mm, BarOrientation bars) const {
  const auto pj = project_with_jacobian(target_mm);
  if (!pj) return 0.0;
  const auto& J = pj->second;  // |J e_x| or |J e_y|
  return bars == BarOrientation::vertical_bars ? std::hypot(J[0], J[2]) : std::hypot(J[1], J[3]);
}

TargetView::Nyquist TargetView::nyquist(Vec2 target_mm) const {
  return {0.5 * px_per_mm_across(target_mm, BarOrientation::horizontal_bars),
          0.5 * px_per_mm_across(target_mm, BarOrientation::vertical_bars)};
}

bool TargetView::seen_from_behind() const {
  // The camera centre in target coordinates is -R^T t; behind means z > 0.
  const double cz = -(R_[2] * rt_[3] + R_[5] * rt_[4] + R_[8] * rt_[5]);
  return cz > 0;
}

InverseMap::InverseMap(const TargetView& view, double x0, double y0, double x1, double y1,
                       double step)
    : x0_(x0), y0_(y0), step_(step) {
  nx_ = static_cast<int>(std::ceil((x1 - x0) / step)) + 2;
  ny_ = static_cast<int>(std::ceil((y1 - y0) / step)) + 2;
  std::vector<Vec2> px;
  px.reserve(static_cast<size_t>(nx_) * ny_);
  for (int j = 0; j < ny_; ++j)
    for (int i = 0; i < nx_; ++i) px.push_back({x0 + i * step, y0 + j * step});
  const auto t = view.target_from_pixels(px);
  grid_.resize(t.size());
  valid_.resize(t.size());
  for (size_t k = 0; k < t.size(); ++k) {
    valid_[k] = t[k].has_value();
    if (t[k]) grid_[k] = *t[k];
  }
}

std::optional<Vec2> InverseMap::at(double x, double y) const {
  const double gx = (x - x0_) / step_, gy = (y - y0_) / step_;
  const int i = static_cast<int>(std::floor(gx)), j = static_cast<int>(std::floor(gy));
  if (i < 0 || j < 0 || i + 1 >= nx_ || j + 1 >= ny_) return std::nullopt;
  const size_t k00 = static_cast<size_t>(j) * nx_ + i, k10 = k00 + 1, k01 = k00 + nx_, k11 = k01 + 1;
  if (!(valid_[k00] && valid_[k10] && valid_[k01] && valid_[k11])) return std::nullopt;
  const double a = gx - i, b = gy - j;
  return (1 - b) * ((1 - a) * grid_[k00] + a * grid_[k10]) + b * ((1 - a) * grid_[k01] + a * grid_[k11]);
}

}  // namespace tactres
