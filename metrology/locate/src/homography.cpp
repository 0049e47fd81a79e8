#include "homography.h"

#include <Eigen/Dense>
#include <cmath>
#include <numbers>

namespace tactres::locate_detail {

Vec2 map_point(const Homography& H, Vec2 p, double* w_out) {
  const double w = H[6] * p.x + H[7] * p.y + H[8];
  if (w_out) *w_out = w;
  return {(H[0] * p.x + H[1] * p.y + H[2]) / w, (H[3] * p.x + H[4] * p.y + H[5]) / w};
}

MapJacobian map_jacobian(const Homography& H, Vec2 p) {
  const double w = H[6] * p.x + H[7] * p.y + H[8];
  const Vec2 q = map_point(H, p);
  return {(H[0] - q.x * H[6]) / w, (H[1] - q.x * H[7]) / w, (H[3] - q.y * H[6]) / w,
          (H[4] - q.y * H[7]) / w};
}

namespace {

// Hartley's normalisation: the points' centroid to the origin, their mean
// distance from it to sqrt(2). nullopt if they all coincide.
std::optional<Eigen::Matrix3d> normaliser(std::span<const Vec2> pts) {
  Vec2 mean{};
  for (const Vec2& p : pts) mean = mean + p;
  mean = (1.0 / static_cast<double>(pts.size())) * mean;
  double spread = 0.0;
  for (const Vec2& p : pts) spread += norm(p - mean);
  spread /= static_cast<double>(pts.size());
  if (!(spread > 0.0) || !std::isfinite(spread)) return std::nullopt;
  const double s = std::numbers::sqrt2 / spread;
  Eigen::Matrix3d T;
  T << s, 0, -s * mean.x, 0, s, -s * mean.y, 0, 0, 1;
  return T;
}

}  // namespace

std::optional<DltSolution> homography_dlt(std::span<const Vec2> from, std::span<const Vec2> to) {
  const std::size_t n = from.size();
  if (n < 4 || to.size() != n) return std::nullopt;
  const auto T1 = normaliser(from), T2 = normaliser(to);
  if (!T1 || !T2) return std::nullopt;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(2 * n), 9);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d X = *T1 * Eigen::Vector3d(from[i].x, from[i].y, 1.0);
    const Eigen::Vector3d x = *T2 * Eigen::Vector3d(to[i].x, to[i].y, 1.0);
    const auto r = static_cast<Eigen::Index>(2 * i);
    A.block<1, 3>(r, 3) = -X.transpose();
    A.block<1, 3>(r, 6) = x.y() * X.transpose();
    A.block<1, 3>(r + 1, 0) = X.transpose();
    A.block<1, 3>(r + 1, 6) = -x.x() * X.transpose();
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeFullV);
  const Eigen::VectorXd sv = svd.singularValues();
  if (sv.size() < 8 || !(sv(0) > 0.0)) return std::nullopt;
  DltSolution sol;
  sol.sv_largest = sv(0);
  sol.sv_eighth = sv(7);
  // H = T2^-1 Hn T1 is linear in Hn: the pair keeps spanning the same family.
  auto denormalised = [&](Eigen::Index column, Homography& out) {
    const Eigen::VectorXd h = svd.matrixV().col(column);
    Eigen::Matrix3d Hn;
    Hn << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);
    const Eigen::Matrix3d H = T2->inverse() * Hn * *T1;
    if (!H.allFinite()) return false;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) out[3 * r + c] = H(r, c);
    return true;
  };
  if (!denormalised(8, sol.least_squares) || !denormalised(7, sol.runner_up)) return std::nullopt;
  return sol;
}

std::optional<Homography> fit_homography(std::span<const Vec2> from, std::span<const Vec2> to) {
  const auto sol = homography_dlt(from, to);
  if (!sol || !sol->unique()) return std::nullopt;
  return sol->least_squares;
}

}  // namespace tactres::locate_detail
