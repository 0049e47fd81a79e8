// fit_pinhole_and_pose (pose.h): when there is no camera model, a pinhole
// focal length fitted together with the pose.

#include <ceres/ceres.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "disc_centroid.h"
#include "homography.h"
#include "pose_internal.h"
#include "tactres/locate/pose.h"

namespace tactres {

using namespace locate_detail;

namespace {

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

}  // namespace

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

namespace {

// The initial focal length f (left at the prior when the view cannot tell)
// and pose, from the homography between the target plane and the observed
// centroids relative to the principal point centre_px; nullopt if the
// centroids are degenerate.
//
// H between the target plane and centred pixels is ~ diag(f, f, 1)
// [r1 r2 t]; r1.r2 = 0 and |r1| = |r2| give two linear equations in
// w = 1/f^2, solved in least squares. Near fronto-parallel they carry no
// information (and may give w <= 0): then the prior stands.
std::optional<RtCameraFromTarget> initial_pinhole_pose(std::span<const DiscObservation> discs,
                                                       const std::vector<std::size_t>& observed,
                                                       Vec2 centre_px, double f_prior, double& f) {
  std::vector<Vec2> target, centred;
  for (std::size_t i : observed) {
    target.push_back(discs[i].center_mm);
    centred.push_back(*discs[i].centroid_px - centre_px);
  }
  const auto fitted = fit_homography(target, centred);
  if (!fitted) return std::nullopt;
  const Eigen::Matrix3d Hpx = to_eigen(*fitted);
  {
    const Eigen::Matrix3d& H = Hpx;
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
  const Eigen::Matrix3d Hn = Eigen::Vector3d(1.0 / f, 1.0 / f, 1.0).asDiagonal() * Hpx;
  return pose_from_homography(Hn, mean);
}

// The covariances of the solved problem's parameter blocks rt and f: f's
// standard deviation (and whether the data, not the prior of standard
// deviation f_sigma, decide it) and, with want_rt, rt's.
void pinhole_covariances(ceres::Problem& problem, RtCameraFromTarget& rt, double& f,
                         double f_sigma, bool want_rt, PinholePoseResult& out) {
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  co.num_threads = 1;
  ceres::Covariance covariance(co);
  const std::vector<std::pair<const double*, const double*>> blocks = {
      {rt.data(), rt.data()}, {&f, &f}};
  if (!covariance.Compute(blocks, &problem)) return;
  double var_f = 0.0;
  std::array<double, 36> c{};
  if (covariance.GetCovarianceBlock(&f, &f, &var_f) && std::isfinite(var_f) && var_f >= 0.0) {
    out.focal_sigma_px_per_px = std::sqrt(var_f);
    out.focal_determined_by_data = std::sqrt(var_f) < 0.5 * f_sigma;
  }
  if (want_rt && covariance.GetCovarianceBlock(rt.data(), rt.data(), c.data()) &&
      std::all_of(c.begin(), c.end(), [](double v) { return std::isfinite(v); }))
    out.pose.covariance_rt_per_px2 = c;
}

}  // namespace

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
  double f = f_prior;
  const auto guess = initial_pinhole_pose(discs, observed, Vec2{cx, cy}, f_prior, f);
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
  if (!solve_pose_problem(problem, po, "the pinhole + pose fit", result, summary)) return out;
  const CameraModel camera = CameraModel::pinhole(f, f, cx, cy, image_width, image_height);
  if (!finish_result(camera, discs, observed, po, rt, result)) return out;
  if (summary.termination_type != ceres::CONVERGENCE)
    result.problem = "the pinhole + pose fit stopped before converging: " + summary.message;
  pinhole_covariances(problem, rt, f, f_sigma, po.compute_covariance, out);
  out.focal_px = f;
  out.camera = camera;
  result.usable = true;
  return out;
}

}  // namespace tactres
