// Unit tests of the truth and of whole renders on a tiny hand-made layout.
#include <cmath>

#include <doctest/doctest.h>

#include "reference_renderer.h"

using namespace reference;

namespace {

// A 10 x 10 mm layout: one big square (the "patch") and a vertical-bar
// triplet of group 1 element 1 (2 lp/mm, bars 0.25 mm), plus a horizontal one.
Layout tiny_layout() {
  const nlohmann::json j = {
      {"schema", "tactres.target/1"},
      {"size_mm", {10, 10}},
      {"relief_height_mm", 0.1},
      {"elements",
       {{{"group", 1}, {"element", 1}, {"lp_per_mm", 2.0}, {"bar_width_mm", 0.25}, {"orientation", "vertical_bars"},
         {"bars_mm", {{6, 6, 6.25, 7.25}, {6.5, 6, 6.75, 7.25}, {7, 6, 7.25, 7.25}}}},
        {{"group", 1}, {"element", 3}, {"lp_per_mm", 2.52}, {"bar_width_mm", 0.198}, {"orientation", "horizontal_bars"},
         {"bars_mm", {{6, 2, 7, 2.198}, {6, 2.396, 7, 2.594}, {6, 2.792, 7, 2.99}}}}}},
      {"artwork",
       {{{"kind", "rect"}, {"mm", {1, 1, 4, 4}}},
        {{"kind", "rect"}, {"mm", {6, 6, 6.25, 7.25}}},
        {{"kind", "rect"}, {"mm", {6.5, 6, 6.75, 7.25}}},
        {{"kind", "rect"}, {"mm", {7, 6, 7.25, 7.25}}},
        {{"kind", "disc"}, {"center_mm", {2, 8}}, {"radius_mm", 0.5}}}}};
  return parse_layout(j);
}

}  // namespace

TEST_CASE("renderer: truth m(f), the interpolated limit and the discrete limit") {
  const double sigma_mm = 0.1;
  const double f_lim = interpolated_limit_lp_per_mm(sigma_mm, 0.1);
  CHECK(m_true(sigma_mm, f_lim) == doctest::Approx(0.1).epsilon(1e-12));
  CHECK(m_true(sigma_mm, 0) == 1.0);
  CHECK(f_lim == doctest::Approx(3.41542).epsilon(1e-5));  // sqrt(ln 10 / (2 pi^2)) / sigma

  const Layout L = tiny_layout();
  const Camera cam = Camera::pinhole(640, 480, 500, 500, 319.5, 239.5);
  Pose pose;
  pose.distance_mm = 25;
  const Truth t = make_truth(L, cam, pose, sigma_mm);
  REQUIRE(t.elements.size() == 2);
  const TruthElement* v = t.find(1, 1, "vertical_bars");
  REQUIRE(v);
  CHECK(v->m == doctest::Approx(std::exp(-2 * M_PI * M_PI * 0.01 * 4)));
  CHECK(v->px_per_bar == doctest::Approx(0.25 * 500 / 25).epsilon(1e-9));
  CHECK(v->in_view);
  // Element centre (6.625, 6.625) mm -> camera (1.625, 1.625, 25) -> pixel.
  CHECK(v->center_px[0] == doctest::Approx(319.5 + 500 * 1.625 / 25));
  CHECK(t.vertical_bars.resolved_any);
  CHECK(t.vertical_bars.group == 1);
  CHECK(t.vertical_bars.element == 1);
  CHECK(t.vertical_bars.beyond_finest);  // the only element is resolved
  CHECK(t.vertical_bars.interpolated_lp_per_mm == doctest::Approx(f_lim));
  // With a larger blur the single vertical element is not resolved at all.
  const Truth t2 = make_truth(L, cam, pose, 0.2);
  CHECK_FALSE(t2.vertical_bars.resolved_any);
}

TEST_CASE("renderer: an albedo render is the analytic blurred pattern at each pixel centre") {
  const Layout L = tiny_layout();
  const Camera cam = Camera::pinhole(640, 480, 500, 500, 319.5, 239.5);
  Pose pose;
  pose.distance_mm = 25;
  Scene s;
  s.sigma_mm = 0.08;
  const Image im = render_image(L, cam, pose, s);
  const RigidTransform T = camera_from_target(pose, 10, 10);
  const BlurredPattern p(L.ink_rects_mm, s.sigma_mm);
  for (auto [x, y] : {std::pair{100, 100}, std::pair{319, 239}, std::pair{450, 330}, std::pair{0, 0}}) {
    std::vector<Vec3> rays;
    cam.unproject_row(y, rays);
    Vec2 mm;
    REQUIRE(intersect_target_plane(T, rays[x], mm));
    // Pinhole: pixel (x, y) sees (x - cx) / f * 25 + 5 mm.
    CHECK(mm[0] == doctest::Approx((x - 319.5) / 500 * 25 + 5));
    CHECK(im.at(x, y) == doctest::Approx(0.85 - 0.8 * p.coverage(mm[0], mm[1])).epsilon(1e-6));
  }
  // Deep inside the square (2.5, 2.5) mm: ink; far outside: ground.
  const Vec2 q = cam.project(T.apply({2.5, 2.5, 0}));
  CHECK(im.at(int(std::lround(q[0])), int(std::lround(q[1]))) == doctest::Approx(0.05f));
  CHECK(im.at(5, 5) == doctest::Approx(0.85f));
  s.light_bars_on_dark = true;
  const Image inv = render_image(L, cam, pose, s);
  CHECK(inv.at(int(std::lround(q[0])), int(std::lround(q[1]))) == doctest::Approx(0.85f));
}

TEST_CASE("renderer: relief is level + gain * l . grad(G * h), peaking at gain h / (sqrt(2 pi) sigma) on an edge") {
  const Layout L = tiny_layout();
  const Camera cam = Camera::pinhole(640, 480, 500, 500, 319.5, 239.5);
  Pose pose;
  pose.distance_mm = 25;
  Scene s;
  s.mode = "relief";
  s.sigma_mm = 0.08;
  s.light_azimuth_deg = 0;  // light along +x: only x-slopes show
  s.gain_per_slope = 0.5;
  const Image im = render_image(L, cam, pose, s);
  const RigidTransform T = camera_from_target(pose, 10, 10);
  // The square's left edge x = 1 mm at y = 2.5 mm: the slope there is
  // 0.1 mm * g(0) = 0.1 / (sqrt(2 pi) 0.08), positive (height rises with x).
  const Vec2 q = cam.project(T.apply({1, 2.5, 0}));  // x = 1 mm is at pixel 239.5: between two pixels
  const double peak = 0.5 * 0.1 / (std::sqrt(2 * M_PI) * 0.08);
  CHECK(level_step(L, s) == doctest::Approx(peak));
  const double px_mm = 25.0 / 500;  // mm per pixel
  const double expect = 0.5 + peak * std::exp(-0.5 * (0.5 * px_mm / 0.08) * (0.5 * px_mm / 0.08));
  CHECK(im.at(int(std::floor(q[0])), int(std::lround(q[1]))) == doctest::Approx(expect).epsilon(1e-6));
  CHECK(im.at(int(std::ceil(q[0])), int(std::lround(q[1]))) == doctest::Approx(expect).epsilon(1e-6));
  // Flat top and flat ground: the level.
  const Vec2 c = cam.project(T.apply({2.5, 2.5, 0}));
  CHECK(im.at(int(std::lround(c[0])), int(std::lround(c[1]))) == doctest::Approx(0.5f));
  CHECK(im.at(5, 5) == doctest::Approx(0.5f));
}

TEST_CASE("renderer: noise sigma follows the SNR definition and is reproducible by seed") {
  const Layout L = tiny_layout();
  Scene s;
  s.snr_db = 40;
  CHECK(noise_sigma(L, s) == doctest::Approx(0.8 / 100));
  s.snr_db = 20;
  CHECK(noise_sigma(L, s) == doctest::Approx(0.8 / 10));
  s.snr_db = 0;
  CHECK(noise_sigma(L, s) == 0);
  Image a, b;
  a.width_px = b.width_px = 200;
  a.height_px = b.height_px = 200;
  a.values.assign(40000, 0.5f);
  b.values = a.values;
  add_gaussian_noise(a, 0.01, 7);
  add_gaussian_noise(b, 0.01, 7);
  CHECK(a.values == b.values);
  double sum2 = 0;
  for (float v : a.values) sum2 += (v - 0.5) * (v - 0.5);
  CHECK(std::sqrt(sum2 / a.values.size()) == doctest::Approx(0.01).epsilon(0.02));
}
