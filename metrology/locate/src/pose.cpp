// fit_pose (pose.h): the pose through a camera model, its robust initial
// guess, and the projection helpers.

#include "tactres/locate/pose.h"

#include <ceres/ceres.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>

#include "disc_centroid.h"
#include "homography.h"
#include "pose_internal.h"

extern "C" {
#include <mrcal/poseutils.h>
}

namespace tactres {

namespace locate_detail {

namespace {

bool finite(Vec2 v) { return std::isfinite(v.x) && std::isfinite(v.y); }

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

}  // namespace

ceres::LossFunction* make_loss(const PoseOptions& o) {
  switch (o.loss) {
    case RobustLoss::none: return nullptr;
    case RobustLoss::huber: return new ceres::HuberLoss(o.loss_scale_px);
    case RobustLoss::cauchy: return new ceres::CauchyLoss(o.loss_scale_px);
  }
  return nullptr;
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

bool solve_pose_problem(ceres::Problem& problem, const PoseOptions& options, const std::string& what,
                        PoseResult& result, ceres::Solver::Summary& summary) {
  ceres::Solve(solver_options(options), &problem, &summary);
  result.solver_report = summary.BriefReport();
  if (summary.IsSolutionUsable()) return true;
  result.problem = what + " failed: " + summary.message;
  return false;
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

Eigen::Matrix3d to_eigen(const Homography& H) {
  Eigen::Matrix3d M;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) M(r, c) = H[3 * r + c];
  return M;
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

}  // namespace locate_detail

using namespace locate_detail;

namespace {

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
  return pose_from_homography(to_eigen(*H), mean);
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
  if (!solve_pose_problem(problem, options, "the pose fit", result, summary)) return result;
  if (!finish_result(camera, discs, observed, options, rt, result)) return result;
  if (summary.termination_type != ceres::CONVERGENCE)
    result.problem = "the pose fit stopped before converging: " + summary.message;
  if (options.compute_covariance) result.covariance_rt_per_px2 = covariance_of(problem, rt.data());
  result.usable = true;
  return result;
}

}  // namespace tactres
