#include "censored_level.h"

#include <algorithm>
#include <cmath>

#include <doctest/doctest.h>

#include "tactres/util/rng.h"

namespace tactres::profiles_detail {

namespace {

// n Gaussian draws (Box-Muller on the reproducible stream) of mean `level`
// and sd `sd`, clipped at black as a sensor or an 8-bit file clips them.
std::vector<double> clipped_draws(int n, double level, double sd, std::uint64_t stream) {
  std::vector<double> v;
  for (int k = 0; k < n; ++k) {
    const double u1 = std::max(1e-12, uniform01(stream, 2 * k)), u2 = uniform01(stream, 2 * k + 1);
    const double z = std::sqrt(-2 * std::log(u1)) * std::cos(2 * M_PI * u2);
    v.push_back(std::max(0.0, level + sd * z));
  }
  return v;
}


// The mean of a bin a quarter or more clipped reads high; the likelihood
// reads the level, and its error covers the truth at the stated rate.
void check_coverage(double level, double sd, double min_clipped_share) {
  CAPTURE(level);
  int covered = 0, clipped_total = 0, pixels = 0;
  const int trials = 400;
  double mean_bias = 0, bias = 0;
  for (int t = 0; t < trials; ++t) {
    const std::vector<double> v = clipped_draws(120, level, sd, 1000 + t);
    clipped_total += static_cast<int>(std::count(v.begin(), v.end(), 0.0));
    pixels += static_cast<int>(v.size());
    double mean = 0;
    for (double x : v) mean += x / v.size();
    mean_bias += (mean - level) / trials;
    const std::optional<CensoredLevel> c = level_clipped_at_black(v);
    REQUIRE(c);
    CHECK(c->sigma > 0);
    CHECK(c->sigma < 0.3 * sd);  // sd / sqrt(120) = 0.09 sd unclipped, more where more clipped
    CHECK(c->sigma_px == doctest::Approx(sd).epsilon(0.35));
    bias += (c->value - level) / trials;
    covered += std::abs(c->value - level) <= 2 * c->sigma;
  }
  CHECK(clipped_total > min_clipped_share * pixels);
  CHECK(mean_bias > 0.12 * sd);        // what the plain mean would report
  CHECK(std::abs(bias) < 0.02 * sd);   // 400 trials: the mean's own sd is ~0.005 sd
  // 2 sigma covers 95.4 %; 400 trials put the count's own sd at 1 %.
  CHECK(covered >= 0.92 * trials);
  CHECK(covered <= 0.99 * trials);
}

}  // namespace

TEST_CASE("a bin's level past black clipping: a quarter clipped, the level and an error that covers it") {
  check_coverage(0.02, 0.03, 0.2);
}

TEST_CASE("a bin's level past black clipping: three fifths clipped, still the level") {
  check_coverage(-0.008, 0.03, 0.55);
}

TEST_CASE("a bin's level past black clipping: refused where the unclipped pixels cannot fix it") {
  // Too few unclipped pixels.
  std::vector<double> few = clipped_draws(kMinUnclippedPixels - 1, 0.2, 0.03, 8);
  few.resize(40, 0.0);
  CHECK_FALSE(level_clipped_at_black(few));
  // No spread among them: one code value (its error is quantisation).
  std::vector<double> flat(50, 0.01);
  flat[0] = flat[1] = 0;
  CHECK_FALSE(level_clipped_at_black(flat));
  // Well above black, a few clipped: about the mean of all.
  const std::optional<CensoredLevel> c = level_clipped_at_black(clipped_draws(500, 0.1, 0.04, 9));
  REQUIRE(c);
  CHECK(c->value == doctest::Approx(0.1).epsilon(0.03));
}

}  // namespace tactres::profiles_detail
