#include "tactres/locate/pose.h"

#include <doctest/doctest.h>

#include <Eigen/Dense>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <random>
#include <string>

extern "C" {
#include <mrcal/poseutils.h>
}

#include "tactres/targets/layout.h"

namespace tactres {
namespace {

const std::filesystem::path kCameras =
    std::filesystem::path(TACTRES_SOURCE_DIR) / "examples" / "cameras";

constexpr double kDeg = std::numbers::pi / 180.0;
// The reference centroid uses a much finer polygon than the fit (48), so the
// fit's own discretisation error is part of what the tests measure.
constexpr int kTruthBoundaryPoints = 720;

const CameraModel& wide_angle() {
  static const CameraModel m = CameraModel::load(kCameras / "wide_angle.cameramodel");
  return m;
}
const CameraModel& pinhole() {
  static const CameraModel m = CameraModel::load(kCameras / "pinhole.cameramodel");
  return m;
}

std::vector<Fiducial> layout_fiducials() {
  static const TargetLayout layout = make_layout({});
  return layout.fiducials;
}

// rt that rotates by `r` (Rodrigues, rad) and puts the target point
// `anchor_mm` at `anchor_camera_mm`.
RtCameraFromTarget make_rt(std::array<double, 3> r, Vec2 anchor_mm, Vec3 anchor_camera_mm) {
  RtCameraFromTarget rt{r[0], r[1], r[2], 0, 0, 0};
  const double x_in[3] = {anchor_mm.x, anchor_mm.y, 0.0};
  double x_out[3];
  mrcal_transform_point_rt(x_out, nullptr, nullptr, rt.data(), x_in);
  rt[3] = anchor_camera_mm.x - x_out[0];
  rt[4] = anchor_camera_mm.y - x_out[1];
  rt[5] = anchor_camera_mm.z - x_out[2];
  return rt;
}

// r_a then r_b: R = R_b * R_a.
std::array<double, 3> compose(std::array<double, 3> r_b, std::array<double, 3> r_a) {
  std::array<double, 3> out{};
  mrcal_compose_r(out.data(), nullptr, nullptr, r_b.data(), r_a.data());
  return out;
}

std::vector<DiscObservation> observe(const CameraModel& camera, const RtCameraFromTarget& rt,
                                     double noise_px = 0.0, unsigned seed = 1) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_px);
  std::vector<DiscObservation> discs = disc_observations(layout_fiducials());
  for (DiscObservation& d : discs) {
    const auto c = project_disc_centroid(camera, rt, d.center_mm, d.radius_mm, kTruthBoundaryPoints);
    REQUIRE(c.has_value());
    d.centroid_px = *c + (noise_px > 0 ? Vec2{noise(rng), noise(rng)} : Vec2{});
  }
  return discs;
}

// Rotation error as the angle of R_fit^T R_true, and translation error.
Eigen::Matrix3d rotation(const RtCameraFromTarget& rt) {
  Eigen::Matrix<double, 3, 3, Eigen::RowMajor> R;
  mrcal_R_from_r(R.data(), nullptr, rt.data());
  return R;
}
double rotation_error_rad(const RtCameraFromTarget& a, const RtCameraFromTarget& b) {
  return Eigen::AngleAxisd(rotation(a).transpose() * rotation(b)).angle();
}
double translation_error_mm(const RtCameraFromTarget& a, const RtCameraFromTarget& b) {
  return std::hypot(a[3] - b[3], a[4] - b[4], a[5] - b[5]);
}

struct Scene {
  std::string name;
  const CameraModel* camera;
  RtCameraFromTarget rt;
  bool behind;
};

// The target's middle at 26 mm in front of the camera, as in a 35 x 35 x 30 mm
// sensor. Mirrored scenes turn the target about its y axis, so that the
// camera looks at the printed face from behind.
std::vector<Scene> wide_angle_scenes() {
  const Vec2 mid{10.0, 10.0};
  const std::array<double, 3> flip{0.0, std::numbers::pi, 0.0};
  // Near the corner: the target's middle on the ray through pixel
  // (1120, 595), turned so that its BR disc points into the corner. At 26 mm
  // the 20 mm target would not fit between the image centre and the corner;
  // at 45 mm it does, with BR ~60 px from the corner, where the lens is most
  // distorted.
  const Vec2 corner_px{1120.0, 595.0};
  const Vec3 ray = *wide_angle().unproject(std::span<const Vec2>(&corner_px, 1))[0];
  const double d = 45.0;
  return {
      {"fronto-parallel", &wide_angle(), make_rt({0, 0, 0}, mid, {0, 0, 26}), false},
      {"rotated 37 deg in plane", &wide_angle(), make_rt({0, 0, 37 * kDeg}, mid, {0.4, -0.3, 26}), false},
      {"tilted 30 deg", &wide_angle(),
       make_rt(compose({0, 0, 12 * kDeg}, {30 * kDeg, 0, 0}), mid, {0.5, 0.8, 26}), false},
      {"mirrored (seen from behind)", &wide_angle(), make_rt(flip, mid, {0, 0, 26}), true},
      {"mirrored and tilted 20 deg", &wide_angle(),
       make_rt(compose({0, 20 * kDeg, 0}, compose({0, 0, -25 * kDeg}, flip)), mid, {-0.6, 0.2, 26}),
       true},
      {"near the image corner", &wide_angle(),
       make_rt({0.0, 0.0, -16 * kDeg}, mid, {d * ray.x / ray.z, d * ray.y / ray.z, d}), false},
  };
}

double max_abs(const std::array<double, 12>& a) {
  double m = 0;
  for (double v : a) m = std::max(m, std::abs(v));
  return m;
}

}  // namespace

TEST_CASE("project_disc_centroid equals the exact ellipse centre under a pinhole") {
  // Under a pinhole the image of a circle is a conic C' = H^-T C H^-1 with
  // H = K [r1 r2 t]; its area centroid is the conic's centre. The projected
  // centre of the disc is NOT: that is why the fit predicts centroids.
  const CameraModel& cam = pinhole();
  const auto rt = make_rt(compose({0, 0, 20 * kDeg}, {35 * kDeg, 0, 0}), {10, 10}, {-5, 4, 24});
  double R[9];
  mrcal_R_from_r(R, nullptr, rt.data());
  const auto intr = cam.intrinsics();
  Eigen::Matrix3d K;
  K << intr[0], 0, intr[2], 0, intr[1], intr[3], 0, 0, 1;
  Eigen::Matrix3d Rt;
  Rt << R[0], R[1], rt[3], R[3], R[4], rt[4], R[6], R[7], rt[5];
  const Eigen::Matrix3d Hinv = (K * Rt).inverse();
  double largest_offset = 0.0;
  for (const Fiducial& f : layout_fiducials()) {
    const double a = f.center_mm.x, b = f.center_mm.y, r = 1.2;  // a larger disc: a larger effect
    Eigen::Matrix3d C;
    C << 1, 0, -a, 0, 1, -b, -a, -b, a * a + b * b - r * r;
    const Eigen::Matrix3d Ci = Hinv.transpose() * C * Hinv;
    const Eigen::Vector2d centre =
        Ci.topLeftCorner<2, 2>().ldlt().solve(-Ci.topRightCorner<2, 1>());
    const auto c720 = project_disc_centroid(cam, rt, f.center_mm, r, 720);
    const auto c48 = project_disc_centroid(cam, rt, f.center_mm, r, 48);
    const auto projected_centre = project_target_point(cam, rt, f.center_mm);
    REQUIRE(c720);
    REQUIRE(c48);
    REQUIRE(projected_centre);
    // The polygon's vertices are projectively (not affinely) regular on the
    // ellipse, so the raw polygon centroid is off by O(1/N^2) (~4e-3 px at
    // N = 48 here); the Richardson step leaves O(1/N^4).
    CHECK(norm(*c720 - Vec2{centre.x(), centre.y()}) < 1e-8);
    CHECK(norm(*c48 - Vec2{centre.x(), centre.y()}) < 5e-5);
    largest_offset = std::max(largest_offset, norm(*projected_centre - Vec2{centre.x(), centre.y()}));
  }
  CHECK(largest_offset > 0.1);
}

TEST_CASE("project_disc_centroid's analytic Jacobian matches central differences") {
  for (const Scene& s : wide_angle_scenes()) {
    CAPTURE(s.name);
    for (const Fiducial& f : layout_fiducials()) {
      std::array<double, 12> J{};
      REQUIRE(project_disc_centroid(*s.camera, s.rt, f.center_mm, f.radius_mm, 48, &J));
      std::array<double, 12> diff{};
      for (int c = 0; c < 6; ++c) {
        const double h = c < 3 ? 1e-6 : 1e-5;
        auto a = s.rt, b = s.rt;
        a[c] += h;
        b[c] -= h;
        const Vec2 qa = *project_disc_centroid(*s.camera, a, f.center_mm, f.radius_mm, 48);
        const Vec2 qb = *project_disc_centroid(*s.camera, b, f.center_mm, f.radius_mm, 48);
        diff[c] = J[c] - (qa.x - qb.x) / (2 * h);
        diff[6 + c] = J[6 + c] - (qa.y - qb.y) / (2 * h);
      }
      CHECK(max_abs(diff) < 1e-4 * max_abs(J));
    }
  }
}

TEST_CASE("the synthetic scenes keep every fiducial on the imager") {
  for (const Scene& s : wide_angle_scenes()) {
    CAPTURE(s.name);
    double nearest_corner = 1e9;
    for (const DiscObservation& d : observe(*s.camera, s.rt)) {
      const Vec2 c = *d.centroid_px;
      // A disc is < 15 px in radius in these scenes: it lies wholly inside.
      CHECK(c.x > 15);
      CHECK(c.y > 15);
      CHECK(c.x < 1279 - 15);
      CHECK(c.y < 719 - 15);
      nearest_corner = std::min(nearest_corner, norm(c - Vec2{1279, 719}));
    }
    if (s.name == "near the image corner") CHECK(nearest_corner < 120.0);
    CHECK((camera_center_in_target_mm(s.rt).z > 0) == s.behind);
  }
}

TEST_CASE("fit_pose recovers known poses through the wide-angle lens, noise-free") {
  for (const Scene& s : wide_angle_scenes()) {
    CAPTURE(s.name);
    const auto discs = observe(*s.camera, s.rt);
    const PoseResult r = fit_pose(*s.camera, discs);
    CAPTURE(r.problem);
    CAPTURE(r.solver_report);
    REQUIRE(r.usable);
    MESSAGE(s.name << ": rotation error " << rotation_error_rad(r.rt_camera_from_target_mm, s.rt)
                   << " rad, translation error "
                   << translation_error_mm(r.rt_camera_from_target_mm, s.rt) << " mm, RMS "
                   << r.rms_px << " px");
    CHECK(rotation_error_rad(r.rt_camera_from_target_mm, s.rt) < 1e-4);
    CHECK(translation_error_mm(r.rt_camera_from_target_mm, s.rt) < 1e-3);
    CHECK(r.rms_px < 0.01);
    CHECK(r.seen_from_behind == s.behind);
    CHECK(r.residuals_px.size() == 5);
    CHECK(r.observed_disc_indices == std::vector<std::size_t>{0, 1, 2, 3, 4});
    CHECK_FALSE(r.solver_report.empty());
    CHECK(r.covariance_rt_per_px2.has_value());
  }
}

TEST_CASE("the homography guess alone lands close to the pose, mirrored or not") {
  for (const Scene& s : wide_angle_scenes()) {
    CAPTURE(s.name);
    std::vector<Vec2> target, px;
    for (const DiscObservation& d : observe(*s.camera, s.rt)) {
      target.push_back(d.center_mm);
      px.push_back(*d.centroid_px);
    }
    std::vector<Vec3> rays;
    for (const auto& ray : s.camera->unproject(px)) rays.push_back(*ray);
    const auto guess = initial_pose_from_homography(target, rays);
    REQUIRE(guess);
    // Centroids stand in for centres here, so the guess is close, not exact.
    CHECK(rotation_error_rad(*guess, s.rt) < 0.02);
    CHECK(translation_error_mm(*guess, s.rt) < 0.3);
    CHECK((camera_center_in_target_mm(*guess).z > 0) == s.behind);
  }
}

TEST_CASE("with 0.1 px noise the residual RMS and the pose scatter match the noise") {
  const double sigma = 0.1;
  const Scene s = wide_angle_scenes()[2];  // tilted
  const int trials = 40;
  double sum_rms2 = 0.0, sum_mahalanobis = 0.0;
  for (int i = 0; i < trials; ++i) {
    const PoseResult r = fit_pose(*s.camera, observe(*s.camera, s.rt, sigma, 100 + i));
    REQUIRE(r.usable);
    REQUIRE(r.covariance_rt_per_px2);
    sum_rms2 += r.rms_px * r.rms_px;
    Eigen::Matrix<double, 6, 6, Eigen::RowMajor> cov(r.covariance_rt_per_px2->data());
    Eigen::Matrix<double, 6, 1> e;
    for (int k = 0; k < 6; ++k) e(k) = r.rt_camera_from_target_mm[k] - s.rt[k];
    sum_mahalanobis += e.dot((sigma * sigma * cov).ldlt().solve(e));
  }
  // 10 residual coordinates, 6 parameters: E[rms^2] = 2 sigma^2 (10 - 6) / 10.
  const double rms = std::sqrt(sum_rms2 / trials);
  MESSAGE("noise 0.1 px: RMS " << rms << " px, mean Mahalanobis " << sum_mahalanobis / trials);
  CHECK(rms > 0.7 * sigma * std::sqrt(0.8));
  CHECK(rms < 1.3 * sigma * std::sqrt(0.8));
  // The covariance predicts the scatter: chi-square with 6 degrees of freedom.
  CHECK(sum_mahalanobis / trials > 3.0);
  CHECK(sum_mahalanobis / trials < 10.0);
}

TEST_CASE("an outlier on one of five discs is down-weighted by the robust loss") {
  const Scene s = wide_angle_scenes()[2];  // tilted
  PoseOptions plain;
  plain.loss = RobustLoss::none;
  // Each disc in turn is misdetected by 7.2 px; the others carry 0.05 px noise.
  for (std::size_t bad = 0; bad < 5; ++bad) {
    CAPTURE(bad);
    auto discs = observe(*s.camera, s.rt, 0.05, 7);
    discs[bad].centroid_px = *discs[bad].centroid_px + Vec2{6.0, -4.0};
    const PoseResult robust = fit_pose(*s.camera, discs);
    const PoseResult ls = fit_pose(*s.camera, discs, plain);
    REQUIRE(robust.usable);
    REQUIRE(ls.usable);
    const double robust_t = translation_error_mm(robust.rt_camera_from_target_mm, s.rt);
    const double ls_t = translation_error_mm(ls.rt_camera_from_target_mm, s.rt);
    const double robust_r = rotation_error_rad(robust.rt_camera_from_target_mm, s.rt);
    const double ls_r = rotation_error_rad(ls.rt_camera_from_target_mm, s.rt);
    MESSAGE("outlier on disc " << bad << ": translation error " << robust_t << " mm (Cauchy) vs "
                               << ls_t << " mm (least squares); rotation " << robust_r << " vs "
                               << ls_r << " rad");
    CHECK(robust_t < 0.5 * ls_t);
    CHECK(robust_r < 0.5 * ls_r);
    // The misdetected disc keeps (most of) its error; the others fit.
    CHECK(norm(robust.residuals_px[bad]) > 5.0);
    for (std::size_t i = 0; i < 5; ++i)
      if (i != bad) CHECK(norm(robust.residuals_px[i]) < 1.0);
  }
}

TEST_CASE("fit_pose works with a missing disc and reports too few or degenerate discs") {
  const Scene s = wide_angle_scenes()[1];
  auto discs = observe(*s.camera, s.rt);
  discs[1].centroid_px.reset();  // T3 not found
  const PoseResult four = fit_pose(*s.camera, discs);
  REQUIRE(four.usable);
  CHECK(rotation_error_rad(four.rt_camera_from_target_mm, s.rt) < 1e-4);
  CHECK(translation_error_mm(four.rt_camera_from_target_mm, s.rt) < 1e-3);
  CHECK(four.observed_disc_indices == std::vector<std::size_t>{0, 2, 3, 4});
  CHECK(four.residuals_px.size() == 4);

  discs[4].centroid_px.reset();
  const PoseResult three = fit_pose(*s.camera, discs);
  CHECK_FALSE(three.usable);
  CHECK(three.problem == "only 3 of 5 fiducial discs were found; the pose needs at least 4");
  CHECK(three.solver_report.empty());

  // Four collinear discs (the top edge) cannot fix a pose.
  std::vector<DiscObservation> line;
  for (double x : {1.0, 5.0, 9.0, 17.0}) {
    DiscObservation d{{x, 1.0}, 0.6, std::nullopt};
    d.centroid_px = project_disc_centroid(*s.camera, s.rt, d.center_mm, d.radius_mm, 720);
    line.push_back(d);
  }
  const PoseResult degenerate = fit_pose(*s.camera, line);
  CHECK_FALSE(degenerate.usable);
  CHECK(degenerate.problem.find("degenerate") != std::string::npos);
}

TEST_CASE("fit_pose and its options reject invalid input") {
  PoseOptions o;
  o.boundary_points = 4;
  CHECK_THROWS_AS(o.validate(), std::invalid_argument);
  o = {};
  o.loss_scale_px = 0.0;
  CHECK_THROWS_AS(o.validate(), std::invalid_argument);
  auto discs = observe(wide_angle(), wide_angle_scenes()[0].rt);
  discs[0].radius_mm = -1.0;
  CHECK_THROWS_AS(fit_pose(wide_angle(), discs), std::invalid_argument);
  CHECK_THROWS_AS(project_disc_centroid(wide_angle(), wide_angle_scenes()[0].rt, {1, 1}, 0.6, 2),
                  std::invalid_argument);
}

TEST_CASE("a target behind the camera projects to nothing") {
  const auto rt = make_rt({0, 0, 0}, {10, 10}, {0, 0, -26});
  CHECK_FALSE(project_target_point(wide_angle(), rt, {10, 10}).has_value());
  CHECK_FALSE(project_disc_centroid(wide_angle(), rt, {10, 10}, 0.6).has_value());
  const auto front = make_rt({0, 0, 0}, {10, 10}, {0, 0, 26});
  const auto q = project_target_point(pinhole(), front, {10, 10});
  REQUIRE(q);
  CHECK(std::abs(q->x - 639.5) < 1e-9);
  CHECK(std::abs(q->y - 359.5) < 1e-9);
}

TEST_CASE("fit_pinhole_and_pose recovers the focal length of a tilted pinhole view") {
  const auto rt = make_rt(compose({0, 0, 15 * kDeg}, {0, 28 * kDeg, 0}), {10, 10}, {0.5, -0.4, 26});
  const auto discs = observe(pinhole(), rt);
  const PinholePoseResult r = fit_pinhole_and_pose(1280, 720, discs);
  CAPTURE(r.pose.problem);
  REQUIRE(r.pose.usable);
  REQUIRE(r.camera.has_value());
  MESSAGE("pinhole fit: f = " << r.focal_px << " px (true 560), RMS " << r.pose.rms_px << " px");
  CHECK(std::abs(r.focal_px / 560.0 - 1.0) < 0.005);
  CHECK(r.focal_determined_by_data);
  CHECK(r.camera->is_pinhole());
  CHECK(r.camera->intrinsics()[2] == 639.5);
  CHECK(r.camera->intrinsics()[3] == 359.5);
  CHECK(r.pose.rms_px < 0.01);
  CHECK(rotation_error_rad(r.pose.rt_camera_from_target_mm, rt) < 1e-3);

  // The prior pulls f slightly toward its centre (1280 px); nearly without
  // it, noise-free data give f almost exactly.
  PinholePoseOptions weak;
  weak.prior_focal_sigma_rel = 100.0;
  const PinholePoseResult unbiased = fit_pinhole_and_pose(1280, 720, discs, weak);
  REQUIRE(unbiased.pose.usable);
  CHECK(std::abs(unbiased.focal_px / 560.0 - 1.0) < 1e-5);
  CHECK(translation_error_mm(unbiased.pose.rt_camera_from_target_mm, rt) < 1e-3);

  // With 0.1 px noise the focal length still lands within 0.5 %.
  const PinholePoseResult noisy = fit_pinhole_and_pose(1280, 720, observe(pinhole(), rt, 0.1, 3));
  REQUIRE(noisy.pose.usable);
  CHECK(std::abs(noisy.focal_px / 560.0 - 1.0) < 0.005);
}

TEST_CASE("fit_pinhole_and_pose on a fronto-parallel view: focal length from the prior, mapping exact") {
  const auto rt = make_rt({0, 0, 10 * kDeg}, {10, 10}, {0.3, 0.2, 26});
  const auto discs = observe(pinhole(), rt);
  const PinholePoseResult r = fit_pinhole_and_pose(1280, 720, discs);
  REQUIRE(r.pose.usable);
  CHECK_FALSE(r.focal_determined_by_data);
  CHECK(r.pose.rms_px < 0.01);
  // Whatever the focal length, the target maps onto the same pixels.
  for (Vec2 p : {Vec2{3, 4}, Vec2{10, 10}, Vec2{17, 15}}) {
    const auto truth = project_target_point(pinhole(), rt, p);
    const auto fitted = project_target_point(*r.camera, r.pose.rt_camera_from_target_mm, p);
    REQUIRE(truth);
    REQUIRE(fitted);
    CHECK(norm(*truth - *fitted) < 0.01);
  }
  CHECK_THROWS_AS(fit_pinhole_and_pose(0, 720, discs), std::invalid_argument);
}

}  // namespace tactres
