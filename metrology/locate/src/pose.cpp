#include "tactres/locate/pose.h"

#include <ceres/ceres.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <stdexcept>

extern "C" {
#include <mrcal/poseutils.h>
}

namespace tactres {

namespace {

bool finite(Vec2 v) { return std::isfinite(v.x) && std::isfinite(v.y); }

// Workspace and core of the projected-disc centroid, shared by the public
// helper and the Ceres cost functions.
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
  DiscCentroidEvaluator(const CameraModel& camera, Vec2 center_mm, double radius_mm, int n)
      : camera_(camera), n_(static_cast<std::size_t>(n)), target_(n_), p_(n_), J_rt_(18 * n_),
        q_(n_), dq_dp_(6 * n_), dC_dq_(4 * n_) {
    for (std::size_t k = 0; k < n_; ++k) {
      const double theta = 2.0 * std::numbers::pi * static_cast<double>(k) / static_cast<double>(n_);
      target_[k] = {center_mm.x + radius_mm * std::cos(theta),
                    center_mm.y + radius_mm * std::sin(theta), 0.0};
    }
  }

  // centroid; dC_drt (2x6 row-major) and dC_dintrinsics (2 x Ni row-major)
  // are filled if not null. Returns false if any vertex cannot be projected or
  // the polygon is degenerate.
  bool evaluate(const double* rt, Vec2* centroid, double* dC_drt, double* dC_dintrinsics) {
    const bool want_rt = dC_drt != nullptr;
    const bool want_intr = dC_dintrinsics != nullptr;
    const std::size_t ni = camera_.num_intrinsics();
    for (std::size_t k = 0; k < n_; ++k) {
      const double x_in[3] = {target_[k].x, target_[k].y, target_[k].z};
      double x_out[3];
      mrcal_transform_point_rt(x_out, want_rt ? &J_rt_[18 * k] : nullptr, nullptr, rt, x_in);
      p_[k] = {x_out[0], x_out[1], x_out[2]};
    }
    if (want_intr) dq_di_.assign(2 * ni * n_, 0.0);
    const bool ok = camera_.project_into(p_, q_, want_rt ? std::span<double>(dq_dp_) : std::span<double>(),
                                         want_intr ? std::span<double>(dq_di_) : std::span<double>(),
                                         {});
    if (!ok) return false;

    // One Richardson step: the inscribed polygon's centroid error is
    // c2/N^2 + O(1/N^4) (the vertices sample a smooth periodic curve), so
    // (4 C_N - C_{N/2}) / 3, with C_{N/2} from every other vertex, cancels
    // the leading term at no extra projection cost: at N = 48 the error
    // drops from ~4e-3 px to ~2e-5 px for a 1.2 mm disc tilted 35 degrees
    // (pose_test.cpp compares with the exact ellipse centre).
    Vec2 c_full, c_half;
    if (!polygon_centroid(1, &c_full, want_rt || want_intr, 4.0 / 3.0, true)) return false;
    if (!polygon_centroid(2, &c_half, want_rt || want_intr, -1.0 / 3.0, false)) return false;
    *centroid = (4.0 / 3.0) * c_full - (1.0 / 3.0) * c_half;
    if (!want_rt && !want_intr) return true;

    if (want_rt) {
      std::fill(dC_drt, dC_drt + 12, 0.0);
      for (std::size_t k = 0; k < n_; ++k) {
        const double* d = &dC_dq_[4 * k];
        const double* g = &dq_dp_[6 * k];
        // M = dC/dq (2x2) * dq/dp (2x3)
        double m[6];
        for (int r = 0; r < 2; ++r)
          for (int c = 0; c < 3; ++c) m[3 * r + c] = d[2 * r] * g[c] + d[2 * r + 1] * g[3 + c];
        const double* j = &J_rt_[18 * k];  // 3x6
        for (int r = 0; r < 2; ++r)
          for (int c = 0; c < 6; ++c)
            dC_drt[6 * r + c] += m[3 * r] * j[c] + m[3 * r + 1] * j[6 + c] + m[3 * r + 2] * j[12 + c];
      }
    }
    if (want_intr) {
      std::fill(dC_dintrinsics, dC_dintrinsics + 2 * ni, 0.0);
      for (std::size_t k = 0; k < n_; ++k) {
        const double* d = &dC_dq_[4 * k];
        const double* g = &dq_di_[2 * ni * k];  // 2 x ni
        for (int r = 0; r < 2; ++r)
          for (std::size_t c = 0; c < ni; ++c)
            dC_dintrinsics[ni * r + c] += d[2 * r] * g[c] + d[2 * r + 1] * g[ni + c];
      }
    }
    return true;
  }

 private:
  // Shoelace centroid of the polygon through every `stride`-th projected
  // vertex. If `want_gradient`, adds weight * dC/dq_k into dC_dq_ (cleared
  // first if `clear`).
  bool polygon_centroid(std::size_t stride, Vec2* centroid, bool want_gradient, double weight,
                        bool clear) {
    const std::size_t m = n_ / stride;
    auto vertex = [&](std::size_t j) { return q_[(j % m) * stride] - q_[0]; };
    double a2 = 0.0, sx = 0.0, sy = 0.0;
    for (std::size_t j = 0; j < m; ++j) {
      const Vec2 a = vertex(j), b = vertex(j + 1);
      const double c = a.x * b.y - b.x * a.y;
      a2 += c;
      sx += (a.x + b.x) * c;
      sy += (a.y + b.y) * c;
    }
    // A polygon narrower than ~1e-6 px^2 is a disc seen edge-on.
    if (!(std::abs(a2) > 1e-6) || !std::isfinite(a2)) return false;
    const double cx = sx / (3.0 * a2), cy = sy / (3.0 * a2);
    *centroid = q_[0] + Vec2{cx, cy};
    if (!want_gradient) return true;
    if (clear) std::fill(dC_dq_.begin(), dC_dq_.end(), 0.0);
    // dC/dq_k, 2x2 per vertex: [dCx/dx dCx/dy; dCy/dx dCy/dy].
    for (std::size_t j = 0; j < m; ++j) {
      const Vec2 pv = vertex(j + m - 1);  // previous vertex
      const Vec2 cv = vertex(j);          // this vertex
      const Vec2 nv = vertex(j + 1);      // next vertex
      const double c_prev = pv.x * cv.y - cv.x * pv.y;
      const double c_this = cv.x * nv.y - nv.x * cv.y;
      const double da2_dx = nv.y - pv.y;
      const double da2_dy = pv.x - nv.x;
      const double dsx_dx = c_this + (cv.x + nv.x) * nv.y + c_prev - (pv.x + cv.x) * pv.y;
      const double dsx_dy = -(cv.x + nv.x) * nv.x + (pv.x + cv.x) * pv.x;
      const double dsy_dx = (cv.y + nv.y) * nv.y - (pv.y + cv.y) * pv.y;
      const double dsy_dy = c_this + c_prev - (cv.y + nv.y) * nv.x + (pv.y + cv.y) * pv.x;
      double* d = &dC_dq_[4 * j * stride];
      d[0] += weight * (dsx_dx / (3.0 * a2) - cx * da2_dx / a2);
      d[1] += weight * (dsx_dy / (3.0 * a2) - cx * da2_dy / a2);
      d[2] += weight * (dsy_dx / (3.0 * a2) - cy * da2_dx / a2);
      d[3] += weight * (dsy_dy / (3.0 * a2) - cy * da2_dy / a2);
    }
    return true;
  }

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

// residual = observed - predicted centroid; parameter block: rt (6).
// Ceres evaluates cost functions from one thread here (num_threads = 1), so
// the evaluator's workspace can be reused between calls.
class DiscCentroidCost final : public ceres::SizedCostFunction<2, 6> {
 public:
  DiscCentroidCost(const CameraModel& camera, const DiscObservation& disc, int n)
      : evaluator_(camera, disc.center_mm, disc.radius_mm, n), observed_(*disc.centroid_px) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    double* J = (jacobians != nullptr) ? jacobians[0] : nullptr;
    Vec2 c;
    if (!evaluator_.evaluate(parameters[0], &c, J, nullptr)) return false;
    residuals[0] = observed_.x - c.x;
    residuals[1] = observed_.y - c.y;
    if (J != nullptr)
      for (int i = 0; i < 12; ++i) J[i] = -J[i];
    return true;
  }

 private:
  mutable DiscCentroidEvaluator evaluator_;
  Vec2 observed_;
};

// Pinhole with fx = fy = f and a fixed principal point; parameter blocks
// rt (6) and f (1). The camera is rebuilt from f at each evaluation so that
// projection still goes through mrcal.
class PinholeDiscCost final : public ceres::SizedCostFunction<2, 6, 1> {
 public:
  PinholeDiscCost(int width, int height, const DiscObservation& disc, int n)
      : width_(width), height_(height), disc_(disc), n_(n), observed_(*disc.centroid_px) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const double f = parameters[1][0];
    if (!(std::isfinite(f) && f > 0.0)) return false;
    const CameraModel camera = CameraModel::from_lens(
        "LENSMODEL_PINHOLE", {f, f, 0.5 * (width_ - 1), 0.5 * (height_ - 1)}, width_, height_);
    DiscCentroidEvaluator evaluator(camera, disc_.center_mm, disc_.radius_mm, n_);
    double* J_rt = (jacobians != nullptr) ? jacobians[0] : nullptr;
    const bool want_f = jacobians != nullptr && jacobians[1] != nullptr;
    double J_intr[8];  // 2 x (fx, fy, cx, cy)
    Vec2 c;
    if (!evaluator.evaluate(parameters[0], &c, J_rt, want_f ? J_intr : nullptr)) return false;
    residuals[0] = observed_.x - c.x;
    residuals[1] = observed_.y - c.y;
    if (J_rt != nullptr)
      for (int i = 0; i < 12; ++i) J_rt[i] = -J_rt[i];
    if (want_f) {
      jacobians[1][0] = -(J_intr[0] + J_intr[1]);
      jacobians[1][1] = -(J_intr[4] + J_intr[5]);
    }
    return true;
  }

 private:
  int width_, height_;
  DiscObservation disc_;
  int n_;
  Vec2 observed_;
};

class FocalPriorCost final : public ceres::SizedCostFunction<1, 1> {
 public:
  FocalPriorCost(double f0, double sigma) : f0_(f0), sigma_(sigma) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    residuals[0] = (parameters[0][0] - f0_) / sigma_;
    if (jacobians != nullptr && jacobians[0] != nullptr) jacobians[0][0] = 1.0 / sigma_;
    return true;
  }

 private:
  double f0_, sigma_;
};

ceres::LossFunction* make_loss(const PoseOptions& o) {
  switch (o.loss) {
    case RobustLoss::none: return nullptr;
    case RobustLoss::huber: return new ceres::HuberLoss(o.loss_scale_px);
    case RobustLoss::cauchy: return new ceres::CauchyLoss(o.loss_scale_px);
  }
  return nullptr;
}

ceres::Solver::Options solver_options(const PoseOptions& o) {
  ceres::Solver::Options s;
  s.minimizer_type = ceres::TRUST_REGION;
  s.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  s.linear_solver_type = ceres::DENSE_QR;
  s.max_num_iterations = o.max_iterations;
  // Tight tolerances: the goal is a few thousandths of a pixel, and each
  // iteration costs microseconds.
  s.function_tolerance = 1e-15;
  s.gradient_tolerance = 1e-15;
  s.parameter_tolerance = 1e-13;
  s.num_threads = 1;
  s.logging_type = ceres::SILENT;
  s.minimizer_progress_to_stdout = false;
  return s;
}

void validate_discs(std::span<const DiscObservation> discs) {
  for (std::size_t i = 0; i < discs.size(); ++i) {
    const DiscObservation& d = discs[i];
    if (!finite(d.center_mm) || !(std::isfinite(d.radius_mm) && d.radius_mm > 0.0))
      throw std::invalid_argument("fiducial disc " + std::to_string(i) +
                                  ": centre must be finite and radius positive (mm)");
    if (d.centroid_px && !finite(*d.centroid_px))
      throw std::invalid_argument("fiducial disc " + std::to_string(i) +
                                  ": observed centroid is not finite; leave it empty if the disc "
                                  "was not found");
  }
}

std::vector<std::size_t> observed_indices(std::span<const DiscObservation> discs) {
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < discs.size(); ++i)
    if (discs[i].centroid_px) idx.push_back(i);
  return idx;
}

std::string too_few_message(std::size_t found, std::size_t total) {
  return "only " + std::to_string(found) + " of " + std::to_string(total) +
         " fiducial discs were found; the pose needs at least 4";
}

// Fills residuals, RMS and the side of the target from a converged rt.
// Returns false (with a message) if a disc cannot be projected at rt.
bool finish_result(const CameraModel& camera, std::span<const DiscObservation> discs,
                   const std::vector<std::size_t>& observed, const PoseOptions& options,
                   const RtCameraFromTarget& rt, PoseResult& result) {
  result.rt_camera_from_target_mm = rt;
  result.observed_disc_indices = observed;
  result.residuals_px.clear();
  double sum2 = 0.0;
  for (std::size_t i : observed) {
    const auto c = project_disc_centroid(camera, rt, discs[i].center_mm, discs[i].radius_mm,
                                         options.boundary_points);
    if (!c) {
      result.problem = "fiducial disc " + std::to_string(i) + " cannot be projected at the fitted pose";
      return false;
    }
    const Vec2 r = *discs[i].centroid_px - *c;
    result.residuals_px.push_back(r);
    sum2 += dot(r, r);
  }
  result.rms_px = std::sqrt(sum2 / static_cast<double>(observed.size()));
  result.seen_from_behind = camera_center_in_target_mm(rt).z > 0.0;
  return true;
}

std::optional<std::array<double, 36>> covariance_of(ceres::Problem& problem, const double* rt) {
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  co.num_threads = 1;
  ceres::Covariance covariance(co);
  std::vector<std::pair<const double*, const double*>> blocks = {{rt, rt}};
  if (!covariance.Compute(blocks, &problem)) return std::nullopt;
  std::array<double, 36> out{};
  if (!covariance.GetCovarianceBlock(rt, rt, out.data())) return std::nullopt;
  for (double v : out)
    if (!std::isfinite(v)) return std::nullopt;
  return out;
}

// Normalised DLT (Hartley): H maps (x, y, 1) of `from` to `to` up to scale.
std::optional<Eigen::Matrix3d> fit_homography(std::span<const Vec2> from, std::span<const Vec2> to) {
  const std::size_t n = from.size();
  if (n < 4 || to.size() != n) return std::nullopt;
  auto normaliser = [](std::span<const Vec2> pts) -> std::optional<Eigen::Matrix3d> {
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
  };
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
  // The null space must be one-dimensional: with collinear points (or only
  // four points, three collinear) a second singular value vanishes.
  if (sv.size() < 8 || !(sv(7) > 1e-9 * sv(0))) return std::nullopt;
  const Eigen::VectorXd h = svd.matrixV().col(8);
  Eigen::Matrix3d Hn;
  Hn << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);
  const Eigen::Matrix3d H = T2->inverse() * Hn * *T1;
  if (!H.allFinite()) return std::nullopt;
  return H;
}

// H ~ [r1 r2 t] (target plane to normalised camera coordinates) -> rt.
std::optional<RtCameraFromTarget> pose_from_homography(const Eigen::Matrix3d& H, Vec2 target_mean) {
  const double n1 = H.col(0).norm(), n2 = H.col(1).norm();
  if (!(n1 > 0.0 && n2 > 0.0)) return std::nullopt;
  double lambda = 2.0 / (n1 + n2);
  // The target must lie in front of the camera: positive depth at its middle.
  const double depth = (H * Eigen::Vector3d(target_mean.x, target_mean.y, 1.0)).z();
  if (depth == 0.0 || !std::isfinite(depth)) return std::nullopt;
  if (depth < 0.0) lambda = -lambda;
  const Eigen::Vector3d r1 = lambda * H.col(0), r2 = lambda * H.col(1), t = lambda * H.col(2);
  Eigen::Matrix3d R;
  // r3 = r1 x r2 makes det(R) > 0: a proper rotation whether the target is
  // seen from the front or from behind (mirrored image).
  R << r1, r2, r1.cross(r2);
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0) D(2, 2) = -1.0;
  const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> Rn = svd.matrixU() * D * svd.matrixV().transpose();
  // Not mrcal_r_from_R: it returns r = 0 for a rotation by exactly pi, and
  // a mirrored fronto-parallel view (the usual through-gel view) is exactly
  // that. Eigen goes through a quaternion, which is well-conditioned there.
  const Eigen::AngleAxisd aa{Eigen::Matrix3d(Rn)};
  const Eigen::Vector3d r = aa.angle() * aa.axis();
  RtCameraFromTarget rt{r.x(), r.y(), r.z(), 0.0, 0.0, 0.0};
  rt[3] = t.x();
  rt[4] = t.y();
  rt[5] = t.z();
  for (double v : rt)
    if (!std::isfinite(v)) return std::nullopt;
  return rt;
}

// Robust cost 0.5 * sum rho(|r|^2) of a pose, as Ceres would compute it;
// nullopt if a disc cannot be projected there.
std::optional<double> robust_cost(const CameraModel& camera, std::span<const DiscObservation> discs,
                                  const std::vector<std::size_t>& observed,
                                  const PoseOptions& options, const RtCameraFromTarget& rt) {
  std::unique_ptr<ceres::LossFunction> loss(make_loss(options));
  double cost = 0.0;
  for (std::size_t i : observed) {
    const auto c = project_disc_centroid(camera, rt, discs[i].center_mm, discs[i].radius_mm,
                                         options.boundary_points);
    if (!c) return std::nullopt;
    const Vec2 r = *discs[i].centroid_px - *c;
    double rho[3] = {dot(r, r), 1.0, 0.0};
    if (loss) loss->Evaluate(dot(r, r), rho);
    cost += 0.5 * rho[0];
  }
  return cost;
}

// The initial guess. With 5 or more discs one gross misdetection would also
// bend the all-disc homography, and the robust fit can then settle in a
// local minimum that blames a neighbouring disc (three fiducials share the
// top edge). So the homographies leaving out each disc in turn compete with
// the all-disc one, and the guess with the lowest robust cost wins.
std::optional<RtCameraFromTarget> robust_initial_pose(const CameraModel& camera,
                                                      std::span<const DiscObservation> discs,
                                                      const std::vector<std::size_t>& observed,
                                                      const PoseOptions& options) {
  std::vector<Vec2> px;
  for (std::size_t i : observed) px.push_back(*discs[i].centroid_px);
  const auto rays = camera.unproject(px);
  auto guess_without = [&](std::size_t left_out) {
    std::vector<Vec2> target;
    std::vector<Vec3> good_rays;
    for (std::size_t k = 0; k < observed.size(); ++k)
      if (k != left_out && rays[k]) {
        target.push_back(discs[observed[k]].center_mm);
        good_rays.push_back(*rays[k]);
      }
    return initial_pose_from_homography(target, good_rays);
  };
  std::optional<RtCameraFromTarget> best = guess_without(observed.size());
  std::optional<double> best_cost;
  if (best) best_cost = robust_cost(camera, discs, observed, options, *best);
  if (observed.size() >= 5 && options.loss != RobustLoss::none) {
    for (std::size_t k = 0; k < observed.size(); ++k) {
      const auto g = guess_without(k);
      if (!g) continue;
      const auto cost = robust_cost(camera, discs, observed, options, *g);
      if (cost && (!best_cost || *cost < *best_cost)) {
        best = g;
        best_cost = cost;
      }
    }
  }
  return best;
}

}  // namespace

std::vector<DiscObservation> disc_observations(const std::vector<Fiducial>& fiducials) {
  std::vector<DiscObservation> out;
  out.reserve(fiducials.size());
  for (const Fiducial& f : fiducials) out.push_back({f.center_mm, f.radius_mm, std::nullopt});
  return out;
}

void PoseOptions::validate() const {
  if (boundary_points < 8 || boundary_points > 4096 || boundary_points % 2 != 0)
    throw std::invalid_argument("pose boundary_points must be even and in [8, 4096], got " +
                                std::to_string(boundary_points));
  if (!(std::isfinite(loss_scale_px) && loss_scale_px > 0.0 && loss_scale_px <= 1000.0))
    throw std::invalid_argument("pose loss_scale_px must be in (0, 1000] px, got " +
                                std::to_string(loss_scale_px));
  if (max_iterations < 1 || max_iterations > 10000)
    throw std::invalid_argument("pose max_iterations must be in [1, 10000], got " +
                                std::to_string(max_iterations));
  if (initial_rt)
    for (double v : *initial_rt)
      if (!std::isfinite(v)) throw std::invalid_argument("pose initial_rt must be finite");
}

void PinholePoseOptions::validate() const {
  pose.validate();
  if (!(std::isfinite(prior_focal_px) && prior_focal_px >= 0.0 && prior_focal_px <= 1e6))
    throw std::invalid_argument("prior_focal_px must be 0 (automatic) or in (0, 1e6] px, got " +
                                std::to_string(prior_focal_px));
  if (!(std::isfinite(prior_focal_sigma_rel) && prior_focal_sigma_rel > 0.0 &&
        prior_focal_sigma_rel <= 100.0))
    throw std::invalid_argument("prior_focal_sigma_rel must be in (0, 100], got " +
                                std::to_string(prior_focal_sigma_rel));
}

Vec3 camera_center_in_target_mm(const RtCameraFromTarget& rt) {
  const double zero[3] = {0.0, 0.0, 0.0};
  double c[3];
  // Inverted transform: R^T (x - t) at x = 0.
  mrcal_transform_point_rt_inverted(c, nullptr, nullptr, rt.data(), zero);
  return {c[0], c[1], c[2]};
}

std::vector<ProjectedPoint> project_target_points(const CameraModel& camera,
                                                  const RtCameraFromTarget& rt,
                                                  std::span<const Vec2> target_mm) {
  std::vector<Vec3> p(target_mm.size());
  for (std::size_t i = 0; i < target_mm.size(); ++i) {
    const double x_in[3] = {target_mm[i].x, target_mm[i].y, 0.0};
    double x_out[3];
    mrcal_transform_point_rt(x_out, nullptr, nullptr, rt.data(), x_in);
    p[i] = {x_out[0], x_out[1], x_out[2]};
  }
  return camera.project(p);
}

std::optional<Vec2> project_target_point(const CameraModel& camera, const RtCameraFromTarget& rt,
                                         Vec2 target_mm) {
  const auto q = project_target_points(camera, rt, std::span<const Vec2>(&target_mm, 1));
  if (!q[0].valid) return std::nullopt;
  return q[0].px;
}

std::optional<Vec2> project_disc_centroid(const CameraModel& camera, const RtCameraFromTarget& rt,
                                          Vec2 center_mm, double radius_mm, int boundary_points,
                                          std::array<double, 12>* dcentroid_drt) {
  if (boundary_points < 8 || boundary_points % 2 != 0)
    throw std::invalid_argument("project_disc_centroid: boundary_points must be even and >= 8, got " +
                                std::to_string(boundary_points));
  if (!(std::isfinite(radius_mm) && radius_mm > 0.0))
    throw std::invalid_argument("project_disc_centroid: radius_mm must be positive");
  DiscCentroidEvaluator evaluator(camera, center_mm, radius_mm, boundary_points);
  Vec2 c;
  if (!evaluator.evaluate(rt.data(), &c, dcentroid_drt ? dcentroid_drt->data() : nullptr, nullptr))
    return std::nullopt;
  return c;
}

std::optional<RtCameraFromTarget> initial_pose_from_homography(std::span<const Vec2> target_mm,
                                                               std::span<const Vec3> rays_camera) {
  if (target_mm.size() != rays_camera.size()) return std::nullopt;
  std::vector<Vec2> from, to;
  for (std::size_t i = 0; i < target_mm.size(); ++i) {
    const Vec3& v = rays_camera[i];
    // Rays at or beyond 90 degrees have no (x/z, y/z) on the normalised plane.
    if (!(v.z > 1e-9)) continue;
    from.push_back(target_mm[i]);
    to.push_back({v.x / v.z, v.y / v.z});
  }
  const auto H = fit_homography(from, to);
  if (!H) return std::nullopt;
  Vec2 mean{};
  for (const Vec2& p : from) mean = mean + p;
  mean = (1.0 / static_cast<double>(from.size())) * mean;
  return pose_from_homography(*H, mean);
}

PoseResult fit_pose(const CameraModel& camera, std::span<const DiscObservation> discs,
                    const PoseOptions& options) {
  options.validate();
  validate_discs(discs);
  PoseResult result;
  const std::vector<std::size_t> observed = observed_indices(discs);
  result.observed_disc_indices = observed;
  if (observed.size() < 4) {
    result.problem = too_few_message(observed.size(), discs.size());
    return result;
  }

  RtCameraFromTarget rt{};
  if (options.initial_rt) {
    rt = *options.initial_rt;
  } else {
    const auto guess = robust_initial_pose(camera, discs, observed, options);
    if (!guess) {
      result.problem =
          "no initial pose: the observed fiducial centroids are degenerate (collinear, repeated or "
          "outside the lens model's field)";
      return result;
    }
    rt = *guess;
  }
  result.rt_camera_from_target_mm = rt;

  ceres::Problem problem;
  for (std::size_t i : observed)
    problem.AddResidualBlock(new DiscCentroidCost(camera, discs[i], options.boundary_points),
                             make_loss(options), rt.data());
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options(options), &problem, &summary);
  result.solver_report = summary.BriefReport();
  if (!summary.IsSolutionUsable()) {
    result.problem = "the pose fit failed: " + summary.message;
    return result;  // rt is not read after a failure
  }
  if (!finish_result(camera, discs, observed, options, rt, result)) return result;
  if (summary.termination_type != ceres::CONVERGENCE)
    result.problem = "the pose fit stopped before converging: " + summary.message;
  if (options.compute_covariance) result.covariance_rt_per_px2 = covariance_of(problem, rt.data());
  result.usable = true;
  return result;
}

PinholePoseResult fit_pinhole_and_pose(int image_width, int image_height,
                                       std::span<const DiscObservation> discs,
                                       const PinholePoseOptions& options) {
  if (image_width <= 0 || image_height <= 0)
    throw std::invalid_argument("image size " + std::to_string(image_width) + "x" +
                                std::to_string(image_height) + " is not valid: both must be positive");
  options.validate();
  validate_discs(discs);
  PinholePoseResult out;
  PoseResult& result = out.pose;
  const std::vector<std::size_t> observed = observed_indices(discs);
  result.observed_disc_indices = observed;
  if (observed.size() < 4) {
    result.problem = too_few_message(observed.size(), discs.size());
    return out;
  }
  const double cx = 0.5 * (image_width - 1), cy = 0.5 * (image_height - 1);
  const double f_prior =
      options.prior_focal_px > 0.0 ? options.prior_focal_px : double(std::max(image_width, image_height));
  const double f_sigma = options.prior_focal_sigma_rel * f_prior;

  // Initial focal length: H between the target plane and centred pixels is
  // ~ diag(f, f, 1) [r1 r2 t]; r1.r2 = 0 and |r1| = |r2| give two linear
  // equations in w = 1/f^2, solved in least squares. Near fronto-parallel
  // they carry no information (and may give w <= 0): then use the prior.
  std::vector<Vec2> target, centred;
  for (std::size_t i : observed) {
    target.push_back(discs[i].center_mm);
    centred.push_back(*discs[i].centroid_px - Vec2{cx, cy});
  }
  const auto Hpx = fit_homography(target, centred);
  if (!Hpx) {
    result.problem = "no initial pose: the observed fiducial centroids are degenerate";
    return out;
  }
  double f = f_prior;
  {
    const Eigen::Matrix3d& H = *Hpx;
    const double a1 = H(0, 0) * H(0, 1) + H(1, 0) * H(1, 1), b1 = H(2, 0) * H(2, 1);
    const double a2 = H(0, 0) * H(0, 0) + H(1, 0) * H(1, 0) - H(0, 1) * H(0, 1) - H(1, 1) * H(1, 1);
    const double b2 = H(2, 0) * H(2, 0) - H(2, 1) * H(2, 1);
    const double w = -(a1 * b1 + a2 * b2) / (a1 * a1 + a2 * a2);
    if (std::isfinite(w) && w > 0.0) {
      const double fc = 1.0 / std::sqrt(w);
      if (fc > 0.05 * f_prior && fc < 20.0 * f_prior) f = fc;
    }
  }
  Vec2 mean{};
  for (const Vec2& p : target) mean = mean + p;
  mean = (1.0 / static_cast<double>(target.size())) * mean;
  const Eigen::Matrix3d Hn = Eigen::Vector3d(1.0 / f, 1.0 / f, 1.0).asDiagonal() * *Hpx;
  const auto guess = pose_from_homography(Hn, mean);
  if (!guess) {
    result.problem = "no initial pose: the observed fiducial centroids are degenerate";
    return out;
  }
  RtCameraFromTarget rt = *guess;
  result.rt_camera_from_target_mm = rt;

  const PoseOptions& po = options.pose;
  ceres::Problem problem;
  for (std::size_t i : observed)
    problem.AddResidualBlock(new PinholeDiscCost(image_width, image_height, discs[i], po.boundary_points),
                             make_loss(po), rt.data(), &f);
  problem.AddResidualBlock(new FocalPriorCost(f_prior, f_sigma), nullptr, &f);
  problem.SetParameterLowerBound(&f, 0, 0.01 * f_prior);
  problem.SetParameterUpperBound(&f, 0, 100.0 * f_prior);
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options(po), &problem, &summary);
  result.solver_report = summary.BriefReport();
  if (!summary.IsSolutionUsable()) {
    result.problem = "the pinhole + pose fit failed: " + summary.message;
    return out;  // parameters are not read after a failure
  }
  const CameraModel camera = CameraModel::pinhole(f, f, cx, cy, image_width, image_height);
  if (!finish_result(camera, discs, observed, po, rt, result)) return out;
  if (summary.termination_type != ceres::CONVERGENCE)
    result.problem = "the pinhole + pose fit stopped before converging: " + summary.message;

  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  co.num_threads = 1;
  ceres::Covariance covariance(co);
  const std::vector<std::pair<const double*, const double*>> blocks = {
      {rt.data(), rt.data()}, {&f, &f}};
  if (covariance.Compute(blocks, &problem)) {
    double var_f = 0.0;
    std::array<double, 36> c{};
    if (covariance.GetCovarianceBlock(&f, &f, &var_f) && std::isfinite(var_f) && var_f >= 0.0) {
      out.focal_sigma_px_per_px = std::sqrt(var_f);
      out.focal_determined_by_data = std::sqrt(var_f) < 0.5 * f_sigma;
    }
    if (po.compute_covariance && covariance.GetCovarianceBlock(rt.data(), rt.data(), c.data()) &&
        std::all_of(c.begin(), c.end(), [](double v) { return std::isfinite(v); }))
      result.covariance_rt_per_px2 = c;
  }
  out.focal_px = f;
  out.camera = camera;
  result.usable = true;
  return out;
}

}  // namespace tactres
