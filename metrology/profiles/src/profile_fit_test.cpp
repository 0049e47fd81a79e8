#include <algorithm>
#include <cmath>
#include <numbers>
#include <functional>
#include <random>
#include <stdexcept>

#include <doctest/doctest.h>

#include "tactres/profiles/profile_fit.h"

using namespace tactres;

namespace {

constexpr double kPi = std::numbers::pi;

double phi(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }

struct Bars {
  double w;  // bar width, mm
  bool inside(double u) const {
    for (int k = -1; k <= 1; ++k)
      if (std::abs(u - 2 * k * w) <= 0.5 * w) return true;
    return false;
  }
  // Gaussian-blurred coverage, exact.
  double blurred(double u, double s) const {
    double v = 0;
    for (int k = -1; k <= 1; ++k) {
      const double c = 2 * k * w;
      v += phi((c + 0.5 * w - u) / s) - phi((c - 0.5 * w - u) / s);
    }
    return v;
  }
  double blurred_slope(double u, double s) const {  // d/du of blurred()
    double v = 0;
    for (int k = -1; k <= 1; ++k) {
      const double c = 2 * k * w;
      auto g = [&](double z) { return std::exp(-0.5 * z * z) / std::sqrt(2 * kPi); };
      v += (-g((c + 0.5 * w - u) / s) + g((c - 0.5 * w - u) / s)) / s;
    }
    return v;
  }
};

// Bins of width `bin` over [-half, half]; the fit uses the central +-fit_half.
ProfileData make_profile(const Bars& bars, double bin, double half, double fit_half,
                         const std::function<double(double)>& truth, double noise_sd,
                         std::mt19937_64* rng) {
  ProfileData d;
  const int n = static_cast<int>(std::round(2 * half / bin));
  d.u0_mm = -0.5 * n * bin;
  d.bin_mm = bin;
  d.bin_count = n;
  for (int k = -1; k <= 1; ++k) d.ideal.push_back({2 * k * bars.w - 0.5 * bars.w, 2 * k * bars.w + 0.5 * bars.w, 1.0});
  std::normal_distribution<double> noise(0.0, 1.0);
  std::uniform_real_distribution<double> jitter(-0.4, 0.4);
  std::mt19937_64 jitter_rng(3);
  for (int i = 0; i < n; ++i) {
    // Point samples at a jittered position inside the bin, as pixel centres fall.
    const double u = d.u0_mm + (i + 0.5 + jitter(jitter_rng)) * bin;
    d.value.push_back(truth(u) + (rng ? noise_sd * noise(*rng) : 0.0));
    d.u_mean_mm.push_back(u);
    d.sigma.push_back(noise_sd > 0 ? noise_sd : 1e-4);
    d.count.push_back(4);
  }
  d.fit_begin = static_cast<int>(std::round((half - fit_half) / bin));
  d.fit_end = n - d.fit_begin;
  return d;
}

}  // namespace

TEST_CASE("albedo profile: m equals the Gaussian MTF at the bar frequency") {
  const Bars bars{0.07};  // 7.14 lp/mm
  const double f = 1 / (2 * bars.w);
  for (double sigma_w : {0.2, 0.4, 0.6, 0.7, 0.8}) {
    const double s = sigma_w * bars.w;
    const double c = -0.8;
    auto truth = [&](double u) { return 200.0 * (1 + c * bars.blurred(u, s)); };
    const ProfileData d = make_profile(bars, bars.w / 12, 8 * bars.w, 4 * bars.w, truth, 0, nullptr);
    ProfileFitOptions o;
    o.contrast = c;
    const ProfileFit fit = fit_profile(d, o);
    REQUIRE(fit.usable);
    const double m_true = std::exp(-2 * kPi * kPi * s * s * f * f);
    CAPTURE(sigma_w);
    CHECK(std::abs(fit.transfer(f) - m_true) < 2e-3);
    CHECK(fit.beta == doctest::Approx(2.0).epsilon(0.05));
  }
}

TEST_CASE("a fitted shift finds bars placed off the ideal, and recovers m that the misplacement reads as blur") {
  const Bars bars{0.07};
  const double f = 1 / (2 * bars.w);
  const double s = 0.4 * bars.w, c = -0.8;
  const double m_true = std::exp(-2 * kPi * kPi * s * s * f * f);
  for (double offset_bars : {-0.15, 0.12}) {
    CAPTURE(offset_bars);
    const double offset_mm = offset_bars * bars.w;
    auto truth = [&](double u) { return 200.0 * (1 + c * bars.blurred(u - offset_mm, s)); };
    const ProfileData d = make_profile(bars, bars.w / 12, 8 * bars.w, 4 * bars.w, truth, 0, nullptr);
    ProfileFitOptions o;
    o.contrast = c;
    const ProfileFit fixed = fit_profile(d, o);
    o.fit_shift = true;
    o.max_shift_mm = 0.25 * bars.w;
    const ProfileFit free = fit_profile(d, o);
    REQUIRE(fixed.usable);
    REQUIRE(free.usable);
    CHECK(std::abs(free.shift_mm - offset_mm) < 0.02 * std::abs(offset_mm));  // size and sign
    CHECK(std::abs(free.transfer(f) - m_true) < 2e-3);
    CHECK(fixed.transfer(f) < m_true - 0.02);  // the misplaced ideal reads as blur
  }
  // Its sigma is the spread of the shift over noise draws (within 25 %).
  ProfileFitOptions o;
  o.contrast = c;
  o.fit_shift = true;
  o.max_shift_mm = 0.25 * bars.w;
  std::mt19937_64 rng(11);
  auto truth = [&](double u) { return 200.0 * (1 + c * bars.blurred(u, s)); };
  double sum = 0, sum2 = 0, sigma_sum = 0;
  constexpr int kDraws = 60;
  for (int i = 0; i < kDraws; ++i) {
    const ProfileFit fit = fit_profile(make_profile(bars, bars.w / 4, 8 * bars.w, 4 * bars.w, truth, 4.0, &rng), o);
    REQUIRE(fit.usable);
    sum += fit.shift_mm, sum2 += fit.shift_mm * fit.shift_mm, sigma_sum += fit.shift_sigma_mm;
  }
  const double spread = std::sqrt(sum2 / kDraws - (sum / kDraws) * (sum / kDraws));
  CHECK(sigma_sum / kDraws > 0);
  CHECK(spread / (sigma_sum / kDraws) == doctest::Approx(1.0).epsilon(0.25));
  // Bounded: bars 0.6 bar off stop the shift at the range's edge, on their side.
  auto far = [&](double u) { return 200.0 * (1 + c * bars.blurred(u - 0.6 * bars.w, s)); };
  const ProfileFit edge = fit_profile(make_profile(bars, bars.w / 12, 8 * bars.w, 4 * bars.w, far, 0, nullptr), o);
  REQUIRE(edge.usable);
  CHECK(edge.shift_mm == doctest::Approx(0.25 * bars.w).scale(0).epsilon(1e-6));
  o.max_shift_mm = 0;
  CHECK_THROWS_AS(o.validate(), std::invalid_argument);
}

TEST_CASE("clipped bins as bounds: a censored fit keeps m where clipped values as data bias it") {
  // Dark bars on a ground of 200, contrast -0.95: the bar cores fall to
  // ~10-20 and a camera whose black sits at 60 clips them there. Read as
  // data, the clipped cores look like shallower bars (more blur); as upper
  // bounds (the light there was at most 60), the edges and gaps fix m.
  const Bars bars{0.05};
  const double f = 1 / (2 * bars.w);
  const double s = 0.35 * bars.w, c = -0.95, black = 60;
  auto truth = [&](double u) { return 200.0 * (1 + c * bars.blurred(u, s)); };
  ProfileData d = make_profile(bars, bars.w / 12, 8 * bars.w, 4 * bars.w, truth, 0.5, nullptr);
  int clipped = 0;
  d.bound.assign(d.bin_count, 0);
  for (int i = 0; i < d.bin_count; ++i)
    if (d.value[i] <= black) d.value[i] = black, d.bound[i] = -1, ++clipped;
  REQUIRE(clipped > 10);
  ProfileFitOptions o;
  o.contrast = c;
  o.fit_shape = false;
  const double m_true = std::exp(-2 * kPi * kPi * s * s * f * f);
  const ProfileFit censored = fit_profile(d, o);
  REQUIRE(censored.usable);
  CHECK(censored.bound_count >= 8);
  CHECK(std::abs(censored.transfer(f) - m_true) < 0.01);
  CHECK(censored.chi2_reduced < 3);
  ProfileData as_data = d;
  as_data.bound.clear();
  const ProfileFit naive = fit_profile(as_data, o);
  REQUIRE(naive.usable);
  CHECK(naive.transfer(f) < m_true - 0.05);
  CHECK(naive.chi2_reduced > 10 * censored.chi2_reduced);
  // Saturation is the mirror image: a ground clipped at 190 reads as a
  // lower bound.
  ProfileData bright = make_profile(bars, bars.w / 12, 8 * bars.w, 4 * bars.w, truth, 0.5, nullptr);
  bright.bound.assign(bright.bin_count, 0);
  for (int i = 0; i < bright.bin_count; ++i)
    if (bright.value[i] >= 190) bright.value[i] = 190, bright.bound[i] = 1;
  const ProfileFit sat = fit_profile(bright, o);
  REQUIRE(sat.usable);
  CHECK(std::abs(sat.transfer(f) - m_true) < 0.01);
}

TEST_CASE("reference patch: the contrast is fitted") {
  const Bars wide{1.0};  // use one wide bar as a patch stand-in
  const double s = 0.05;
  auto truth = [&](double u) {
    return 100.0 * (1 - 0.7 * (phi((0.5 - u) / s) - phi((-0.5 - u) / s)));
  };
  ProfileData d = make_profile(wide, 0.01, 1.2, 1.0, truth, 0, nullptr);
  d.ideal = {{-0.5, 0.5, 1.0}};  // a single patch
  ProfileFitOptions o;
  o.fit_contrast = true;
  const ProfileFit fit = fit_profile(d, o);
  REQUIRE(fit.usable);
  CHECK(fit.contrast == doctest::Approx(-0.7).epsilon(2e-3));
  CHECK(fit.b0 == doctest::Approx(100.0).epsilon(1e-3));
}

TEST_CASE("shading profile: the edge-like signature gives the same transfer") {
  const Bars bars{0.05};
  const double f = 1 / (2 * bars.w);
  const double s = 0.6 * bars.w;
  const double c = 0.004;  // relative intensity per unit slope x relief
  auto truth = [&](double u) { return 150.0 * (1 + c * bars.blurred_slope(u, s)); };
  const ProfileData d = make_profile(bars, bars.w / 12, 8 * bars.w, 4 * bars.w, truth, 0, nullptr);
  ProfileFitOptions o;
  o.signature = Signature::shading;
  o.contrast = c;
  const ProfileFit fit = fit_profile(d, o);
  REQUIRE(fit.usable);
  const double m_true = std::exp(-2 * kPi * kPi * s * s * f * f);
  CHECK(std::abs(fit.transfer(f) - m_true) < 3e-3);
}

TEST_CASE("shading profile: a step that changes across the bars (light per point) is held as c + c' u") {
  // The step falls from 1.8 c to 0.2 c across the triplet (u = -+2.5 bar
  // widths), as on the flank of a spot: with c' the model describes the
  // bars and the fit finds the transfer; with the centre's c alone it
  // cannot describe them.
  const Bars bars{0.05};
  const double f = 1 / (2 * bars.w);
  const double s = 0.6 * bars.w;
  const double c = 0.004, slope_per_mm = -0.8 * c / (2.5 * bars.w);
  auto truth = [&](double u) { return 150.0 * (1 + (c + slope_per_mm * u) * bars.blurred_slope(u, s)); };
  const ProfileData d = make_profile(bars, bars.w / 12, 8 * bars.w, 4 * bars.w, truth, 0, nullptr);
  ProfileFitOptions o;
  o.signature = Signature::shading;
  o.contrast = c;
  o.contrast_slope_per_mm = slope_per_mm;
  const double m_true = std::exp(-2 * kPi * kPi * s * s * f * f);
  const ProfileFit with_slope = fit_profile(d, o);
  REQUIRE(with_slope.usable);
  CHECK(std::abs(with_slope.transfer(f) - m_true) < 3e-3);
  o.contrast_slope_per_mm = 0;
  const ProfileFit centre_only = fit_profile(d, o);
  REQUIRE(centre_only.usable);
  CHECK(centre_only.chi2_reduced > 1e4 * with_slope.chi2_reduced);
  o.contrast_slope_per_mm = std::nan("");
  CHECK_THROWS_AS(o.validate(), std::invalid_argument);
}

TEST_CASE("standard errors are calibrated on noisy profiles") {
  const Bars bars{0.07};
  const double f = 1 / (2 * bars.w);
  const double s = 0.6 * bars.w;
  const double m_true = std::exp(-2 * kPi * kPi * s * s * f * f);
  auto truth = [&](double u) { return 100.0 * (1 - 0.8 * bars.blurred(u, s)); };
  std::mt19937_64 rng(7);
  double sum_z2 = 0;
  int n = 0, covered = 0;
  for (int rep = 0; rep < 60; ++rep) {
    const ProfileData d = make_profile(bars, bars.w / 4, 8 * bars.w, 4 * bars.w, truth, 1.0, &rng);
    ProfileFitOptions o;
    o.contrast = -0.8;
    const ProfileFit fit = fit_profile(d, o);
    REQUIRE(fit.usable);
    const double z = (fit.transfer(f) - m_true) / fit.transfer_sigma(f);
    sum_z2 += z * z;
    covered += std::abs(z) <= 2 ? 1 : 0;
    ++n;
  }
  const double rms_z = std::sqrt(sum_z2 / n);
  CHECK(rms_z > 0.6);
  CHECK(rms_z < 1.5);
  CHECK(covered >= 50);  // ~95% expected of 60
}

TEST_CASE("no contrast is a graded failure, not a NaN") {
  const Bars bars{0.07};
  auto flat = [](double) { return 50.0; };
  const ProfileData d = make_profile(bars, bars.w / 8, 8 * bars.w, 4 * bars.w, flat, 0, nullptr);
  ProfileFitOptions o;
  o.fit_contrast = true;
  const ProfileFit fit = fit_profile(d, o);
  if (fit.usable) {
    CHECK(std::isfinite(fit.transfer(0.5 / bars.w)));
    CHECK(std::abs(fit.contrast) < 1e-3);
  } else {
    CHECK_FALSE(fit.problem.empty());
  }
}

TEST_CASE("the fit does not depend on the data's units (a linear float image in any scale)") {
  const Bars bars{0.07};
  const double f = 1 / (2 * bars.w);
  auto truth = [&](double u) { return 1.0 - 0.8 * bars.blurred(u, 0.6 * bars.w); };
  std::mt19937_64 rng(11);
  const ProfileData d = make_profile(bars, bars.w / 4, 8 * bars.w, 4 * bars.w, truth, 0.01, &rng);
  ProfileFitOptions o;
  o.contrast = -0.8;
  const ProfileFit unit = fit_profile(d, o);
  REQUIRE(unit.usable);
  for (double scale : {1e6, 1e-6, 3e3}) {
    ProfileData scaled = d;
    for (double& v : scaled.value) v *= scale;
    for (double& v : scaled.sigma) v *= scale;
    const ProfileFit fit = fit_profile(scaled, o);
    CAPTURE(scale);
    REQUIRE(fit.usable);
    CHECK(fit.transfer(f) == doctest::Approx(unit.transfer(f)).epsilon(1e-6));
    CHECK(fit.transfer_sigma(f) == doctest::Approx(unit.transfer_sigma(f)).epsilon(1e-4));
    CHECK(fit.b0 == doctest::Approx(scale * unit.b0).epsilon(1e-6));
    CHECK(fit.residual_rms == doctest::Approx(scale * unit.residual_rms).epsilon(1e-4));
  }
}

TEST_CASE("the shape's bound: a core with a halo presses beta onto 1, and the unbounded step says where m would go") {
  const Bars bars{0.07};
  const double f = 1 / (2 * bars.w);
  const double c = -0.8;
  // Half the light in a core of 0.3 bar widths, half in a halo of 3:
  // heavier tails than any beta >= 1 gives (beta < 1 in this family).
  const double s_core = 0.3 * bars.w, s_halo = 3.0 * bars.w, core = 0.5;
  auto halo = [&](double u) {
    return 200.0 * (1 + c * (core * bars.blurred(u, s_core) + (1 - core) * bars.blurred(u, s_halo)));
  };
  std::mt19937_64 rng(5);
  const ProfileData d = make_profile(bars, bars.w / 8, 10 * bars.w, 6 * bars.w, halo, 0.05, &rng);
  ProfileFitOptions o;
  o.contrast = c;
  const ProfileFit fit = fit_profile(d, o);
  REQUIRE(fit.usable);
  CHECK(fit.beta == doctest::Approx(o.beta_min));
  CHECK(fit.beta_bound_sigmas > 4);  // 9.2 here
  CHECK(fit.unbounded_step_beta < 0);  // beyond the lower bound, not back into the range
  // In beta's own sigma, as the fit reports it (widened by chi^2).
  CHECK(fit.beta_bound_sigmas == doctest::Approx(-fit.unbounded_step_beta / std::sqrt(fit.var_beta)));
  CHECK(std::abs(fit.transfer_change_unbounded(f)) > 2 * fit.transfer_sigma(f));  // 0.047 against 0.012
  // The step points toward the halo's true transfer at f (0.321), which
  // the bounded family misses (0.275 here).
  const double m_true = core * std::exp(-2 * kPi * kPi * s_core * s_core * f * f) +
                        (1 - core) * std::exp(-2 * kPi * kPi * s_halo * s_halo * f * f);
  const double m = fit.transfer(f);
  CHECK(std::abs(m + fit.transfer_change_unbounded(f) - m_true) < std::abs(m - m_true));

  // A Gaussian LSF ends inside the range: no step, no press.
  const double s = 0.5 * bars.w;
  auto gauss = [&](double u) { return 200.0 * (1 + c * bars.blurred(u, s)); };
  const ProfileFit inside = fit_profile(make_profile(bars, bars.w / 8, 10 * bars.w, 6 * bars.w, gauss, 0.05, &rng), o);
  REQUIRE(inside.usable);
  CHECK(inside.beta > o.beta_min);
  CHECK(inside.beta < o.beta_max);
  CHECK(inside.beta_bound_sigmas == 0);
  CHECK(inside.transfer_change_unbounded(f) == 0);
}

TEST_CASE("the shape's bound from above: a box LSF presses beta onto a bound of 2 from below it") {
  const Bars bars{0.07};
  const double f = 1 / (2 * bars.w);
  const double c = -0.8, a = 0.8 * bars.w;  // a box LSF 0.8 bar wide: flatter than any Gaussian
  // Each bar's coverage blurred by the box: its overlap with [u - a/2, u + a/2], over a.
  auto boxed = [&](double u) {
    double v = 0;
    for (int k = -1; k <= 1; ++k) {
      const double lo = std::max(u - 0.5 * a, 2 * k * bars.w - 0.5 * bars.w);
      const double hi = std::min(u + 0.5 * a, 2 * k * bars.w + 0.5 * bars.w);
      v += std::max(0.0, hi - lo) / a;
    }
    return 200.0 * (1 + c * v);
  };
  std::mt19937_64 rng(9);
  const ProfileData d = make_profile(bars, bars.w / 8, 10 * bars.w, 6 * bars.w, boxed, 0.05, &rng);
  ProfileFitOptions o;
  o.contrast = c;
  o.beta_max = 2;
  const ProfileFit fit = fit_profile(d, o);
  REQUIRE(fit.usable);
  CHECK(fit.beta == doctest::Approx(2.0));
  CHECK(fit.unbounded_step_beta > 0);  // beyond the upper bound
  CHECK(fit.beta_bound_sigmas > 4);
  const double m_true = std::abs(std::sin(kPi * f * a) / (kPi * f * a));  // the box's transfer at f
  const double m = fit.transfer(f);
  CHECK(std::abs(m + fit.transfer_change_unbounded(f) - m_true) < std::abs(m - m_true));
}
