// Camera and pose of the reference renderer: mrcal's C API for every lens
// (a pinhole is mrcal's LENSMODEL_PINHOLE built in memory), and a pose built
// from a few readable numbers. No tactres code.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <stdexcept>

#include "reference_renderer.h"

namespace reference {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

Mat3 multiply(const Mat3& a, const Mat3& b) {
  Mat3 c{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) c[i][j] += a[i][k] * b[k][j];
  return c;
}

Vec3 multiply(const Mat3& a, const Vec3& v) {
  return {a[0][0] * v[0] + a[0][1] * v[1] + a[0][2] * v[2], a[1][0] * v[0] + a[1][1] * v[1] + a[1][2] * v[2],
          a[2][0] * v[0] + a[2][1] * v[1] + a[2][2] * v[2]};
}

Vec3 multiply_transposed(const Mat3& a, const Vec3& v) {
  return {a[0][0] * v[0] + a[1][0] * v[1] + a[2][0] * v[2], a[0][1] * v[0] + a[1][1] * v[1] + a[2][1] * v[2],
          a[0][2] * v[0] + a[1][2] * v[1] + a[2][2] * v[2]};
}

Mat3 rotation_about_z(double angle_deg) {
  const double c = std::cos(angle_deg * kDegToRad), s = std::sin(angle_deg * kDegToRad);
  return Mat3{Vec3{c, -s, 0}, Vec3{s, c, 0}, Vec3{0, 0, 1}};
}

Mat3 rotation_about_x(double angle_deg) {
  const double c = std::cos(angle_deg * kDegToRad), s = std::sin(angle_deg * kDegToRad);
  return Mat3{Vec3{1, 0, 0}, Vec3{0, c, -s}, Vec3{0, s, c}};
}

}  // namespace

Vec3 RigidTransform::apply(const Vec3& p) const {
  const Vec3 r = multiply(rotation, p);
  return {r[0] + translation_mm[0], r[1] + translation_mm[1], r[2] + translation_mm[2]};
}

RigidTransform camera_from_target(const Pose& pose, double target_width_mm, double target_height_mm) {
  // A direct view looks along the target's +z (into its face): camera axes =
  // target axes. A mirrored view looks along -z from behind: a half turn about
  // y, which flips x and z and keeps the rotation proper.
  const Mat3 view = pose.mirrored ? Mat3{Vec3{-1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, 0, -1}}
                                  : Mat3{Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, 0, 1}};
  RigidTransform T;
  T.rotation = multiply(rotation_about_z(pose.roll_deg), multiply(view, rotation_about_x(pose.tilt_deg)));
  const Vec3 centre_mm{0.5 * target_width_mm, 0.5 * target_height_mm, 0};
  const Vec3 rotated_centre = multiply(T.rotation, centre_mm);
  T.translation_mm = {pose.shift_mm[0] - rotated_centre[0], pose.shift_mm[1] - rotated_centre[1],
                      pose.distance_mm - rotated_centre[2]};
  return T;
}

// Not mrcal_r_from_R: it returns r = 0 for a rotation by exactly pi, which is
// what a mirrored, unrolled view is.
Vec3 rodrigues_of(const Mat3& R) {
  const Vec3 w{0.5 * (R[2][1] - R[1][2]), 0.5 * (R[0][2] - R[2][0]), 0.5 * (R[1][0] - R[0][1])};  // sin(a) axis
  const double sin_a = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
  const double cos_a = 0.5 * (R[0][0] + R[1][1] + R[2][2] - 1);
  const double angle = std::atan2(sin_a, cos_a);
  if (sin_a > 1e-6) return {angle * w[0] / sin_a, angle * w[1] / sin_a, angle * w[2] / sin_a};
  if (cos_a > 0) return {w[0], w[1], w[2]};  // near identity: r ~ w
  // Near pi: (R + I) / 2 = axis axis^T; take its largest column.
  int k = 0;
  for (int i = 1; i < 3; ++i)
    if (R[i][i] > R[k][k]) k = i;
  Vec3 axis{0.5 * (R[0][k] + (k == 0)), 0.5 * (R[1][k] + (k == 1)), 0.5 * (R[2][k] + (k == 2))};
  const double n = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
  return {angle * axis[0] / n, angle * axis[1] / n, angle * axis[2] / n};
}

Camera Camera::pinhole(int width_px, int height_px, double fx_px, double fy_px, double cx_px, double cy_px) {
  Camera c;
  c.lensmodel_.type = MRCAL_LENSMODEL_PINHOLE;
  c.lensmodel_name_ = "LENSMODEL_PINHOLE";
  c.intrinsics_ = {fx_px, fy_px, cx_px, cy_px};
  c.width_px_ = width_px;
  c.height_px_ = height_px;
  return c;
}

Camera Camera::from_file(const std::string& cameramodel_path) {
  mrcal_cameramodel_t* model = mrcal_read_cameramodel_file(cameramodel_path.c_str());
  if (!model) throw std::runtime_error("camera: mrcal cannot read " + cameramodel_path);
  Camera c;
  c.lensmodel_ = model->lensmodel;
  const int n = mrcal_lensmodel_num_params(&model->lensmodel);
  c.intrinsics_.assign(model->intrinsics, model->intrinsics + n);
  c.width_px_ = static_cast<int>(model->imagersize[0]);
  c.height_px_ = static_cast<int>(model->imagersize[1]);
  mrcal_free_cameramodel(&model);
  char name[256];
  if (!mrcal_lensmodel_name(name, sizeof name, &c.lensmodel_))
    throw std::runtime_error("camera: unnamed lens model in " + cameramodel_path);
  c.lensmodel_name_ = name;
  return c;
}

void Camera::unproject_row(int row, std::vector<Vec3>& rays) const {
  std::vector<mrcal_point2_t> q(width_px_);
  std::vector<mrcal_point3_t> v(width_px_);
  for (int x = 0; x < width_px_; ++x) {
    q[x].x = x;
    q[x].y = row;
  }
  if (!mrcal_unproject(v.data(), q.data(), width_px_, &lensmodel_, intrinsics_.data()))
    throw std::runtime_error("camera: mrcal_unproject failed");
  rays.resize(width_px_);
  for (int x = 0; x < width_px_; ++x) rays[x] = {v[x].x, v[x].y, v[x].z};
}

Vec2 Camera::project(const Vec3& p_cam_mm) const {
  mrcal_point3_t p;
  p.x = p_cam_mm[0];
  p.y = p_cam_mm[1];
  p.z = p_cam_mm[2];
  mrcal_point2_t q;
  if (!mrcal_project(&q, nullptr, nullptr, &p, 1, &lensmodel_, intrinsics_.data()))
    throw std::runtime_error("camera: mrcal_project failed");
  return {q.x, q.y};
}

void Camera::write_cameramodel(const std::string& path) const {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("camera: cannot write " + path);
  out << "{\n  'lensmodel':  '" << lensmodel_name_ << "',\n  'intrinsics': [";
  char buf[64];
  for (double v : intrinsics_) {
    std::snprintf(buf, sizeof buf, " %.17g,", v);
    out << buf;
  }
  out << " ],\n  'imagersize': [ " << width_px_ << ", " << height_px_ << " ],\n"
      << "  'extrinsics': [ 0, 0, 0, 0, 0, 0 ]\n}\n";
  if (!out) throw std::runtime_error("camera: cannot write " + path);
}

bool intersect_target_plane(const RigidTransform& T, const Vec3& ray_cam, Vec2& xy_mm) {
  // Camera centre and ray in the target frame: o = -R^T t, d = R^T v.
  const Vec3 o = multiply_transposed(T.rotation, T.translation_mm);
  const Vec3 d = multiply_transposed(T.rotation, ray_cam);
  if (std::abs(d[2]) < 1e-12) return false;
  const double s = o[2] / d[2];  // (-o) + s d has z = 0
  if (!(s > 0)) return false;
  xy_mm = {-o[0] + s * d[0], -o[1] + s * d[1]};
  return true;
}

double px_per_mm_along(const Camera& camera, const RigidTransform& T, Vec2 p_mm, Vec2 dir) {
  const double step_mm = 1e-3;
  const Vec2 a = camera.project(T.apply({p_mm[0] - step_mm * dir[0], p_mm[1] - step_mm * dir[1], 0}));
  const Vec2 b = camera.project(T.apply({p_mm[0] + step_mm * dir[0], p_mm[1] + step_mm * dir[1], 0}));
  return std::hypot(b[0] - a[0], b[1] - a[1]) / (2 * step_mm);
}

}  // namespace reference
