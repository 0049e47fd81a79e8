#include "chart_motion.h"

#include <cmath>
#include <random>
#include <vector>

#include <doctest/doctest.h>

using namespace tactres;
using namespace tactres::chart;

namespace {

// Anchors in two columns of a chart (x = 300 and 900 px, y 200..700 px),
// each seen across its bars only: horizontal bars along y, vertical bars
// along x, both turned by `roll_rad` as the moved chart shows them.
std::vector<MotionSample> samples_of(const ChartMotion& truth, double roll_rad, double noise_px, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, noise_px);
  std::vector<MotionSample> out;
  for (const double x : {300.0, 900.0})
    for (const double y : {200.0, 450.0, 700.0})
      for (const Vec2 across : {Vec2{std::cos(roll_rad), std::sin(roll_rad)}, Vec2{-std::sin(roll_rad), std::cos(roll_rad)}}) {
        const Vec2 from{x, y};
        out.push_back({from, across, dot(across, truth.apply(from)) + n(rng)});
      }
  return out;
}

ChartMotion similarity(double roll_rad, double scale, Vec2 offset_px) {
  ChartMotion m;
  m.linear[0] = scale * std::cos(roll_rad), m.linear[1] = -scale * std::sin(roll_rad);
  m.linear[2] = scale * std::sin(roll_rad), m.linear[3] = scale * std::cos(roll_rad);
  m.offset_px = offset_px;
  return m;
}

void check_maps_alike(const ChartMotion& a, const ChartMotion& b, double tol_px) {
  for (const Vec2 p : {Vec2{300, 200}, Vec2{900, 700}, Vec2{600, 450}, Vec2{100, 900}})
    CHECK(norm(a.apply(p) - b.apply(p)) < tol_px);
}

}  // namespace

TEST_CASE("chart motion: a roll and an offset are recovered from one-dimensional anchor shifts") {
  const ChartMotion truth = similarity(0.003, 1.001, {1.7, -0.9});
  const MotionFit fit = fit_chart_motion(samples_of(truth, 0.003, 0.01, 1), 0.3);
  REQUIRE(fit.ok);
  CHECK(fit.affine);
  CHECK(fit.samples_used == 12);
  CHECK(fit.rms_px < 0.02);
  check_maps_alike(fit.motion, truth, 0.05);
}

TEST_CASE("chart motion: an anchor locked on the wrong place is dropped") {
  const ChartMotion truth = similarity(-0.002, 1.0, {-0.6, 2.2});
  std::vector<MotionSample> s = samples_of(truth, -0.002, 0.01, 2);
  s[3].across_px += 1.5;
  const MotionFit fit = fit_chart_motion(s, 0.3);
  REQUIRE(fit.ok);
  CHECK(fit.samples_used == 11);
  check_maps_alike(fit.motion, truth, 0.05);
}

TEST_CASE("chart motion: few anchors give a similarity, too few nothing") {
  const ChartMotion truth = similarity(0.004, 0.999, {0.8, 0.3});
  std::vector<MotionSample> s = samples_of(truth, 0.004, 0.0, 3);
  s.resize(5);  // one column of anchors: not enough for an affine
  const MotionFit fit = fit_chart_motion(s, 0.3);
  REQUIRE(fit.ok);
  CHECK_FALSE(fit.affine);
  check_maps_alike(fit.motion, truth, 0.01);
  s.resize(3);
  CHECK_FALSE(fit_chart_motion(s, 0.3).ok);
}

TEST_CASE("chart motion: anchors all across the same bars cannot place the chart along them") {
  const ChartMotion truth = similarity(0.0, 1.0, {0.5, 0.5});
  std::vector<MotionSample> s;
  for (const MotionSample& m : samples_of(truth, 0.0, 0.0, 4))
    if (m.across.x > 0.5) s.push_back(m);
  CHECK_FALSE(fit_chart_motion(s, 0.3).ok);
}

TEST_CASE("chart motion: a pattern's frame moves with the chart, across its bars") {
  const ChartMotion m = similarity(0.01, 1.02, {3, -2});
  const PatternFrame f({400, 300}, {1, 0}, 47.0);
  for (const BarOrientation o : {BarOrientation::horizontal_bars, BarOrientation::vertical_bars}) {
    const PatternFrame g = m.apply(f, o);
    CHECK(norm(g.center_px - m.apply(f.center_px)) < 1e-9);
    CHECK(g.px_per_mm == doctest::Approx(47.0 * 1.02));
    // A similarity turns every direction alike: the plane's x keeps its image direction.
    CHECK(norm(g.x_dir - (1 / 1.02) * m.apply_linear(f.x_dir)) < 1e-9);
  }
}

namespace {

// A three-bar pattern of bar width `w_mm` centred at `center_mm`, blurred
// by a Gaussian of `blur_mm`, sampled at bins of `bin_mm` starting at an
// arbitrary phase: level = offset + gain * (1 - 0.9 * bars).
LevelProfile blurred_bars(double w_mm, double center_mm, double blur_mm, double bin_mm, double phase_mm,
                          double gain, double offset) {
  LevelProfile p;
  for (double u = -4 * w_mm + phase_mm; u < 4 * w_mm; u += bin_mm) {
    double bars = 0;
    for (int k = -1; k <= 1; ++k) {
      const double c = center_mm + 2 * k * w_mm;
      bars += 0.5 * (std::erf((u - (c - 0.5 * w_mm)) / (std::sqrt(2.0) * blur_mm)) -
                     std::erf((u - (c + 0.5 * w_mm)) / (std::sqrt(2.0) * blur_mm)));
    }
    p.push_back({u, offset + gain * (1 - 0.9 * bars)});
  }
  return p;
}

}  // namespace

TEST_CASE("chart motion: an anchor's shift is matched off the bin grid, through a change of light and focus") {
  const double w = 0.1;  // mm
  const LevelProfile reference = blurred_bars(w, 0.0, 0.03, 0.011, 0.0, 1.0, 0.0);
  for (const double shift : {-0.07, -0.023, 0.0, 0.0137, 0.06}) {
    CAPTURE(shift);
    const LevelProfile now = blurred_bars(w, shift, 0.04, 0.011, 0.004, 0.8, 0.05);
    const auto found = match_shift_mm(now, reference, 0.9 * w);
    REQUIRE(found);
    CHECK(std::abs(*found - shift) < 0.01 * w);
  }
  // Beyond the reach the best lies at its end: no answer rather than a wrong one.
  CHECK_FALSE(match_shift_mm(blurred_bars(w, 0.095, 0.03, 0.011, 0.0, 1.0, 0.0), reference, 0.5 * w).has_value());
}
