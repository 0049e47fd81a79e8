#include <doctest/doctest.h>

#include "scene_fixtures.h"
#include "tactres/live/live_measure.h"

using namespace tactres;
using namespace tactres::testing;

namespace {

// One capture of the default target through the example lens, in memory.
const LoadedImage& capture() {
  static const LoadedImage image = [] {
    TempDir dir("live-unit");
    ViewPose v;
    v.roll_deg = 3;
    Scene s = albedo_scene(v, 1.3, 2);
    SensorOptions sensor = sensor_40db(7);
    sensor.bit_depth = 10;
    s.effects.emplace_back(sensor);
    const RenderResult r = render_scene(s, default_layout(), wide_angle_camera());
    write_image(dir.path / "c.png", r.image, r.bits);
    return load_image(dir.path / "c.png");
  }();
  return image;
}

Frame frame_of(long index, double light) {
  Frame f;
  f.index = index;
  f.image = capture();
  // A new buffer: assigning the product to the copy's Mat would write it
  // into the pixels it shares with capture().
  const cv::Mat scaled = capture().luminance * light;
  f.image->luminance = scaled;
  return f;
}

}  // namespace

TEST_CASE("live measurer: tracked after the first frame; the patch refitted on a change of light and every N frames") {
  LiveOptions o;
  o.measure = MeasureOptions::for_preset(Preset::fast);
  o.refit_every = 3;
  LiveMeasurer live(o, &default_layout(), &wide_angle_camera());
  const double light[] = {0.8, 0.8, 0.8, 0.8, 0.9, 0.9};
  std::vector<bool> refit, tracked;
  for (int i = 0; i < 6; ++i) {
    const LiveFrameResult r = live.measure(frame_of(i, light[i]));
    REQUIRE_MESSAGE(r.measured, r.problem);
    refit.push_back(r.refit);
    tracked.push_back(r.tracked);
  }
  // 0: from scratch; 3: three frames since the fit; 4: the light rose 12 %.
  CHECK(refit == std::vector<bool>{true, false, false, true, true, false});
  CHECK(tracked == std::vector<bool>{false, true, true, true, true, true});
}

TEST_CASE("live measurer: near-limit fits give the limits of fitting every element") {
  LiveOptions all, near;
  all.measure = near.measure = MeasureOptions::for_preset(Preset::fast);
  near.elements = LiveElements::near_limit;
  LiveMeasurer a(all, &default_layout(), &wide_angle_camera()), b(near, &default_layout(), &wide_angle_camera());
  LiveFrameResult ra, rb;
  for (int i = 0; i < 3; ++i) {
    ra = a.measure(frame_of(i, 0.8));
    rb = b.measure(frame_of(i, 0.8));
  }
  REQUIRE(ra.measured);
  REQUIRE(rb.measured);
  for (const auto& [la, lb] : {std::pair(ra.measurement.horizontal, rb.measurement.horizontal),
                               std::pair(ra.measurement.vertical, rb.measurement.vertical)}) {
    CHECK(la.group == lb.group);
    CHECK(la.element == lb.element);
    REQUIRE(la.interpolated_lp_per_mm);
    REQUIRE(lb.interpolated_lp_per_mm);
    CHECK(*la.interpolated_lp_per_mm == doctest::Approx(*lb.interpolated_lp_per_mm).epsilon(1e-6));
  }
}

TEST_CASE("live measurer: a frame without pixels is a row with its problem, and the next starts afresh") {
  LiveOptions o;
  o.measure = MeasureOptions::for_preset(Preset::fast);
  LiveMeasurer live(o, &default_layout(), &wide_angle_camera());
  CHECK(live.measure(frame_of(0, 0.8)).measured);
  Frame bad;
  bad.index = 1;
  bad.problem = "cannot decode image x.png";
  const LiveFrameResult r = live.measure(bad);
  CHECK_FALSE(r.measured);
  CHECK(r.problem == bad.problem);
  const LiveFrameResult next = live.measure(frame_of(2, 0.8));
  CHECK(next.measured);
  CHECK_FALSE(next.tracked);
  CHECK(next.refit);
}

TEST_CASE("live measurer: a frame of another size than the camera model's is a row with its problem") {
  LiveOptions o;
  o.measure = MeasureOptions::for_preset(Preset::fast);
  LiveMeasurer live(o, &default_layout(), &wide_angle_camera());
  CHECK(live.measure(frame_of(0, 0.8)).measured);
  Frame small = frame_of(1, 0.8);
  small.image->luminance = cv::Mat(small.image->luminance, cv::Rect(0, 0, 640, 360)).clone();
  small.image->width = 640;
  small.image->height = 360;
  const LiveFrameResult r = live.measure(small);
  CHECK_FALSE(r.measured);
  CHECK(r.problem.find("imager but the image is 640x360") != std::string::npos);
  CHECK(live.measure(frame_of(2, 0.8)).measured);  // the sequence goes on
}
