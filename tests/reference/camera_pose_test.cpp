// Unit tests of the pose and the projection against hand computations.
#include <cmath>
#include <filesystem>

#include <doctest/doctest.h>

#include "reference_renderer.h"

using namespace reference;

namespace {

double determinant(const Mat3& m) {
  return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
         m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

const Camera kPinhole = Camera::pinhole(1280, 720, 560, 560, 639.5, 359.5);

}  // namespace

TEST_CASE("renderer: a target corner projects where a hand computation puts it") {
  // 20 x 20 mm target, centre on the axis at 26 mm: its top-left corner is at
  // (-10, -10, 26) mm in the camera, so at 639.5 + 560 * -10 / 26 = 424.12 px.
  Pose pose;
  RigidTransform T = camera_from_target(pose, 20, 20);
  Vec2 q = kPinhole.project(T.apply({0, 0, 0}));
  CHECK(q[0] == doctest::Approx(639.5 - 5600.0 / 26));
  CHECK(q[1] == doctest::Approx(359.5 - 5600.0 / 26));
  q = kPinhole.project(T.apply({10, 10, 0}));  // the centre
  CHECK(q[0] == doctest::Approx(639.5));
  CHECK(q[1] == doctest::Approx(359.5));

  // Mirrored: seen from behind, x flips; still a proper rotation.
  pose.mirrored = true;
  T = camera_from_target(pose, 20, 20);
  CHECK(determinant(T.rotation) == doctest::Approx(1));
  q = kPinhole.project(T.apply({0, 0, 0}));
  CHECK(q[0] == doctest::Approx(639.5 + 5600.0 / 26));
  CHECK(q[1] == doctest::Approx(359.5 - 5600.0 / 26));
  // ... and the camera is on the target's +z side.
  CHECK(T.apply({10, 10, -1})[2] == doctest::Approx(27));

  // Tilt 25 deg about the target's x axis: the top-centre point (10, 0) goes to
  // (0, -10 cos 25, 26 - 10 sin 25) mm.
  pose = {};
  pose.tilt_deg = 25;
  T = camera_from_target(pose, 20, 20);
  const double c = std::cos(25 * M_PI / 180), s = std::sin(25 * M_PI / 180);
  q = kPinhole.project(T.apply({10, 0, 0}));
  CHECK(q[0] == doctest::Approx(639.5));
  CHECK(q[1] == doctest::Approx(359.5 - 560 * 10 * c / (26 - 10 * s)));

  // Roll 90 deg about the optical axis: target +x turns to image +y.
  pose = {};
  pose.roll_deg = 90;
  T = camera_from_target(pose, 20, 20);
  q = kPinhole.project(T.apply({20, 10, 0}));
  CHECK(q[0] == doctest::Approx(639.5));
  CHECK(q[1] == doctest::Approx(359.5 + 5600.0 / 26));
  CHECK(determinant(T.rotation) == doctest::Approx(1));

  // The rotation vector of a direct, unrolled view is zero; of a mirrored one, pi about y.
  CHECK(std::abs(rodrigues_of(camera_from_target(Pose{}, 20, 20).rotation)[1]) < 1e-12);
  pose = {};
  pose.mirrored = true;
  CHECK(std::abs(rodrigues_of(camera_from_target(pose, 20, 20).rotation)[1]) == doctest::Approx(M_PI));
}

TEST_CASE("renderer: unproject then intersect returns the target point, pinhole and wide-angle") {
  const Camera wide =
      Camera::from_file(std::string(TACTRES_SOURCE_DIR) + "/examples/cameras/wide_angle.cameramodel");
  CHECK(wide.width_px() == 1280);
  CHECK(wide.lensmodel_name() == "LENSMODEL_OPENCV8");
  Pose pose;
  pose.roll_deg = 17;
  pose.tilt_deg = 20;
  pose.shift_mm = {4, -2};
  for (const Camera* camera : {&kPinhole, &wide}) {
    for (bool mirrored : {false, true}) {
      pose.mirrored = mirrored;
      const RigidTransform T = camera_from_target(pose, 20, 20);
      for (Vec2 p_mm : {Vec2{0, 0}, Vec2{20, 0}, Vec2{3.3, 17.1}, Vec2{19, 19}}) {
        const Vec2 q = camera->project(T.apply({p_mm[0], p_mm[1], 0}));
        // Unproject the pixel nearest q and meet the plane: projecting that
        // point again must land on the pixel centre, close to p_mm.
        const int row = static_cast<int>(std::lround(q[1]));
        const int col = static_cast<int>(std::lround(q[0]));
        REQUIRE(row >= 0);
        REQUIRE(row < camera->height_px());
        std::vector<Vec3> rays;
        camera->unproject_row(row, rays);
        Vec2 back_mm;
        REQUIRE(intersect_target_plane(T, rays[col], back_mm));
        const Vec2 q_back = camera->project(T.apply({back_mm[0], back_mm[1], 0}));
        CHECK(q_back[0] == doctest::Approx(col).epsilon(1e-9).scale(1));
        CHECK(q_back[1] == doctest::Approx(row).epsilon(1e-9).scale(1));
        CHECK(std::hypot(back_mm[0] - p_mm[0], back_mm[1] - p_mm[1]) < 0.1);
      }
    }
  }
}

TEST_CASE("renderer: pixels per mm on a fronto-parallel pinhole view is f / distance") {
  const RigidTransform T = camera_from_target(Pose{}, 20, 20);
  CHECK(px_per_mm_along(kPinhole, T, {10, 10}, {1, 0}) == doctest::Approx(560.0 / 26).epsilon(1e-9));
  CHECK(px_per_mm_along(kPinhole, T, {10, 10}, {0, 1}) == doctest::Approx(560.0 / 26).epsilon(1e-9));
}

TEST_CASE("renderer: a pinhole written as a .cameramodel reads back through mrcal") {
  const std::string path = std::filesystem::temp_directory_path() / "reference_pinhole_test.cameramodel";
  const Camera c = Camera::pinhole(2448, 2048, 2100, 2100, 1223.5, 1023.5);
  c.write_cameramodel(path);
  const Camera back = Camera::from_file(path);
  CHECK(back.lensmodel_name() == "LENSMODEL_PINHOLE");
  CHECK(back.width_px() == 2448);
  CHECK(back.height_px() == 2048);
  REQUIRE(back.intrinsics().size() == 4);
  CHECK(back.intrinsics()[0] == 2100);
  CHECK(back.intrinsics()[3] == 1023.5);
  std::filesystem::remove(path);
}
