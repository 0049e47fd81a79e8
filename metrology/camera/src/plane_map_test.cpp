#include "tactres/camera/plane_map.h"

#include <cmath>

#include <doctest/doctest.h>

#include "tactres/camera/camera_model.h"
#include "tactres/camera/target_view.h"

using namespace tactres;

TEST_CASE("a pattern frame is the pinhole view of a plane facing the camera") {
  // The same similarity through mrcal: a pinhole looking straight at the
  // plane, rotated about the optical axis, at the distance that gives the
  // frame's scale.
  const double focal_px = 1000, theta = 0.3;
  const PatternFrame f({412.5, 233.25}, {std::cos(theta), std::sin(theta)}, 37.5);
  const CameraModel cam = CameraModel::pinhole(focal_px, focal_px, 0, 0, 1000, 800);
  const double z = focal_px / f.px_per_mm;
  const TargetView view(cam, {0, 0, theta, f.center_px.x * z / focal_px, f.center_px.y * z / focal_px, z});
  for (Vec2 p : {Vec2{0, 0}, Vec2{1.5, -0.25}, Vec2{-2, 3}}) {
    const Vec2 a = *f.project(p), b = *view.project(p);
    CHECK(a.x == doctest::Approx(b.x).epsilon(1e-12));
    CHECK(a.y == doctest::Approx(b.y).epsilon(1e-12));
    const Vec2 back = f.to_plane(a);
    CHECK(back.x == doctest::Approx(p.x).epsilon(1e-12));
    CHECK(back.y == doctest::Approx(p.y).epsilon(1e-12));
  }
  CHECK(f.px_per_mm_across({1, 1}, BarOrientation::horizontal_bars) ==
        doctest::Approx(view.px_per_mm_across({1, 1}, BarOrientation::horizontal_bars)).epsilon(1e-12));
}
