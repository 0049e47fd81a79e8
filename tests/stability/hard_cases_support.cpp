// Helpers of the hard_cases_*_test.cpp suites: see hard_cases_support.h.
#include "hard_cases_support.h"

#include <algorithm>
#include <cmath>

#include "tactres/locate/pose.h"

namespace tactres::stability::hard_cases {

using testing::default_layout;
using testing::source_dir;
using testing::wide_angle_camera;

Scene scene_with(ViewPose v, double blur_sigma_px) { return testing::albedo_scene(v, blur_sigma_px, 2); }

LoadedImage as_loaded(const RenderResult& r) { return r.bits > 0 ? integer_image(r.image, r.bits) : float_image(r.image); }

CliRun cli(const Files& f, const std::filesystem::path& image, int expected, std::vector<std::string> extra) {
  const auto no_camera = std::find(extra.begin(), extra.end(), "no-camera");
  if (no_camera != extra.end()) {
    extra.erase(no_camera);
  } else if (std::find(extra.begin(), extra.end(), "--camera") == extra.end()) {
    extra.push_back("--camera");
    extra.push_back((source_dir() / "examples/cameras/wide_angle.cameramodel").string());
  }
  return measure_cli(image, f.layout, f.dir.path, expected, extra);
}

bool any_resolved(const Measurement& m) { return m.horizontal.any_resolved || m.vertical.any_resolved; }

void check_limits_agree(const Limit& a, const Limit& b, double z) {
  CHECK(a.any_resolved == b.any_resolved);
  if (!a.any_resolved || !b.any_resolved) return;
  if (a.interpolated_lp_per_mm && b.interpolated_lp_per_mm) {
    const double u = std::hypot(a.uncertainty_lp_per_mm.value_or(0), b.uncertainty_lp_per_mm.value_or(0));
    CAPTURE(*a.interpolated_lp_per_mm);
    CAPTURE(*b.interpolated_lp_per_mm);
    CAPTURE(u);
    CHECK(std::abs(*a.interpolated_lp_per_mm - *b.interpolated_lp_per_mm) <= z * u + 1e-9);
  } else {
    CHECK(a.group == b.group);
    CHECK(a.element == b.element);
  }
}

void occlude_fiducial(cv::Mat& image, const Scene& s, const CameraModel& cam, const std::string& id, float level) {
  const TargetLayout& L = default_layout();
  const auto rt = s.rt_camera_from_target(L);
  for (const Fiducial& f : L.fiducials) {
    if (f.id != id) continue;
    const auto c = project_target_point(cam, rt, f.center_mm);
    const auto e = project_target_point(cam, rt, {f.center_mm.x + f.radius_mm, f.center_mm.y});
    REQUIRE(c);
    REQUIRE(e);
    const double r = 1.6 * std::hypot(e->x - c->x, e->y - c->y);
    for (int y = int(c->y - r) - 1; y <= int(c->y + r) + 1; ++y)
      for (int x = int(c->x - r) - 1; x <= int(c->x + r) + 1; ++x)
        if (y >= 0 && x >= 0 && y < image.rows && x < image.cols && std::hypot(x - c->x, y - c->y) <= r)
          image.at<float>(y, x) = level;
    return;
  }
  FAIL("no fiducial " << id);
}

const Measured& reference_measurement() {
  static const Measured m = [] {
    const RenderResult r = render_scene(scene_with(), default_layout(), wide_angle_camera());
    return measure_checked(as_loaded(r), &wide_angle_camera());
  }();
  return m;
}

}  // namespace tactres::stability::hard_cases
