#include "tactres/measure/gain_field.h"

#include <cmath>
#include <random>
#include <vector>

#include <doctest/doctest.h>

using namespace tactres;

namespace {

// Samples of a step c(p) = c0 + gx (x - 10) + gy (y - 10) over a 20 mm
// target, with relative noise `noise`.
std::vector<GainSample> samples_of(double c0, double gx, double gy, double noise, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<GainSample> out;
  for (const double x : {3.0, 8.0, 13.0, 17.0})
    for (const double y : {4.0, 11.0, 16.0}) {
      const double c = c0 + gx * (x - 10) + gy * (y - 10);
      out.push_back({{x, y}, c + noise * std::abs(c0) * n(rng), noise * std::abs(c0)});
    }
  return out;
}

std::vector<Vec2> grid() {
  std::vector<Vec2> at;
  for (double x = 2; x <= 18; x += 4)
    for (double y = 2; y <= 18; y += 4) at.push_back({x, y});
  return at;
}

}  // namespace

TEST_CASE("gain field: uniform light keeps the patch's step everywhere") {
  const LevelStep patch{-0.8, 0.004, 1.2};
  // A few per cent of scatter about the patch's step: within the tolerance.
  const GainField f = fit_gain_field(samples_of(-0.8, 0.0, 0.0, 0.02, 1), {10, 10}, patch, grid());
  CHECK_FALSE(f.plane);
  for (const Vec2 p : grid()) {
    const LevelStep s = f.at(p, patch);
    CHECK(s.contrast == patch.contrast);
    CHECK(s.contrast_sigma == patch.contrast_sigma);
  }
}

TEST_CASE("gain field: a gradient is recovered and applied at each point, with its error") {
  const LevelStep patch{-0.8, 0.004, 1.2};
  // The step falls to ~0 at x = 10 + 0.8 / 0.1 = 18 mm and doubles at 2 mm.
  const GainField f = fit_gain_field(samples_of(-0.8, 0.1, 0.02, 0.01, 2), {10, 10}, patch, grid());
  REQUIRE(f.plane);
  CHECK(f.gradient_x_per_mm == doctest::Approx(0.1).epsilon(0.05));
  CHECK(f.gradient_y_per_mm == doctest::Approx(0.02).epsilon(0.3));
  CHECK(f.spread > kStronglyNonUniformSpread);
  const LevelStep left = f.at({2, 10}, patch), far = f.at({18, 10}, patch);
  CHECK(left.contrast == doctest::Approx(-1.6).epsilon(0.03));
  CHECK(left.usable());
  // Where the gain crosses zero the step is no scale: such elements are
  // graded low_signal (element_pipeline.cpp).
  CHECK(std::abs(far.contrast) < 0.06);
  CHECK_FALSE(far.distinct_from_zero(2));
  CHECK(left.contrast_sigma > 0);
  CHECK(left.contrast_sigma < 0.05);
}

TEST_CASE("gain field: too few or collinear samples leave it uniform") {
  const LevelStep patch{0.5, 0.002, 1.0};
  std::vector<GainSample> three = samples_of(0.5, 0.1, 0.0, 0.0, 3);
  three.resize(3);
  CHECK_FALSE(fit_gain_field(three, {10, 10}, patch, grid()).plane);
  std::vector<GainSample> line;
  for (double x = 2; x <= 18; x += 2) line.push_back({{x, 7.0}, 0.5 + 0.1 * (x - 10), 0.01});
  CHECK_FALSE(fit_gain_field(line, {10, 10}, patch, grid()).plane);
}

TEST_CASE("gain field: a small but significant gradient within the tolerance stays uniform") {
  const LevelStep patch{-0.8, 0.001, 1.0};
  // 0.004 / mm over +-8 mm: 4 % at most, clearly measured (noise 0.1 %).
  const GainField f = fit_gain_field(samples_of(-0.8, 0.004, 0.0, 0.001, 4), {10, 10}, patch, grid());
  CHECK_FALSE(f.plane);
}
