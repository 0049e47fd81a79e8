#include "tactres/locate/rectified_search.h"

#include <doctest/doctest.h>

#include <cmath>

#include "scene_fixtures.h"

namespace tactres {
namespace {

TEST_CASE("rectifying_pinhole keeps the wide-angle imager's border rays inside the pinhole view") {
  const CameraModel& cam = testing::wide_angle_camera();
  const std::optional<CameraModel> pin = rectifying_pinhole(cam);
  REQUIRE(pin);
  CHECK(pin->is_pinhole());
  CHECK(pin->imager_width() == cam.imager_width());
  const double scale = pin->intrinsics()[0] / cam.intrinsics()[0];
  CHECK(scale < 1.0);  // barrel distortion: the corners need a shorter focal length
  CHECK(scale >= 0.5);
  // Every border pixel's ray lands inside the pinhole imager.
  const int W = cam.imager_width(), H = cam.imager_height();
  for (Vec2 p : {Vec2{0, 0}, Vec2{W - 1.0, 0}, Vec2{0, H - 1.0}, Vec2{W - 1.0, H - 1.0}, Vec2{W / 2.0, 0}}) {
    const auto ray = cam.unproject(std::span<const Vec2>(&p, 1))[0];
    REQUIRE(ray);
    const auto q = pin->project(std::span<const Vec3>(&*ray, 1))[0];
    REQUIRE(q.valid);
    CHECK(q.px.x >= -0.5);
    CHECK(q.px.x <= W - 0.5);
    CHECK(q.px.y >= -0.5);
    CHECK(q.px.y <= H - 0.5);
  }
}

TEST_CASE("rectify samples the capture along the real lens's rays (a ramp image reads back its own x)") {
  const CameraModel& cam = testing::wide_angle_camera();
  const CameraModel pin = *rectifying_pinhole(cam);
  // An image whose value is its x coordinate: bilinear resampling of a
  // ramp is exact, so each rectified pixel must hold the x at which mrcal
  // projects that pixel's pinhole ray through the real lens.
  cv::Mat ramp(cam.imager_height(), cam.imager_width(), CV_32F);
  for (int y = 0; y < ramp.rows; ++y)
    for (int x = 0; x < ramp.cols; ++x) ramp.at<float>(y, x) = float(x);
  const cv::Mat rect = rectify(ramp, cam, pin);
  const std::vector<double> k = pin.intrinsics();
  double worst = 0;
  for (int y = 40; y < rect.rows - 40; y += 37)
    for (int x = 40; x < rect.cols - 40; x += 41) {
      const Vec3 ray{(x - k[2]) / k[0], (y - k[3]) / k[1], 1.0};
      const auto q = cam.project(std::span<const Vec3>(&ray, 1))[0];
      REQUIRE(q.valid);
      if (q.px.x < 0 || q.px.x > ramp.cols - 1 || q.px.y < 0 || q.px.y > ramp.rows - 1) continue;
      worst = std::max(worst, std::abs(rect.at<float>(y, x) - q.px.x));
      // unrectify_point is the same map for a single point.
      const auto back = unrectify_point({double(x), double(y)}, cam, pin);
      REQUIRE(back);
      CHECK(std::abs(back->x - q.px.x) < 1e-9);
    }
  // OpenCV's remap weighs with 5-bit sub-pixel positions: <= 1/64 px off.
  CHECK(worst < 0.017);
}

}  // namespace
}  // namespace tactres
