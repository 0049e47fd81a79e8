#include <cmath>
#include <numbers>
#include <stdexcept>

#include <doctest/doctest.h>
#include <nlohmann/json.hpp>

#include "tactres/profiles/detectability.h"

using namespace tactres;

namespace {
constexpr double kPi = std::numbers::pi;

// CNR of a Gaussian chain seen at `px_per_mm` with per-pixel noise `noise`:
// every factor of the Rose model varies with f as the header says.
double gaussian_cnr(double f, double sigma_mm, double px_per_mm, double noise) {
  const double m = std::exp(-2 * kPi * kPi * sigma_mm * sigma_mm * f * f);
  const double signal = bar_signal_ptp(m, -0.9, 0.8, Signature::albedo, f);
  return rose_cnr(signal, pixels_per_bar(px_per_mm / (2 * f), 1.0), noise);
}

std::vector<CnrPoint> cnr_series(double sigma_mm, double px_per_mm, double noise) {
  std::vector<CnrPoint> pts;
  for (int g = 0; g <= 4; ++g)
    for (int e = 1; e <= 6; ++e) {
      const double f = std::exp2(g + (e - 1) / 6.0);
      pts.push_back({g, e, f, gaussian_cnr(f, sigma_mm, px_per_mm, noise), 0.0, true});
    }
  return pts;
}
}  // namespace

TEST_CASE("the Rose CNR of a bar: signal times the square root of its pixels over the noise") {
  // A sharp albedo bar, 4 px wide and 20 px long, level step 0.72: the
  // fundamental's peak-to-peak is 4/pi of the step.
  const double s = bar_signal_ptp(1.0, -0.9, 0.8, Signature::albedo, 2.0);
  CHECK(s == doctest::Approx(4 / kPi * 0.72));
  CHECK(pixels_per_bar(4.0, 1.0) == doctest::Approx(80.0));
  CHECK(rose_cnr(s, 80.0, 0.01) == doctest::Approx(s * std::sqrt(80.0) / 0.01));
  // A relief's image is its slope: the signal grows with 2 pi f.
  CHECK(bar_signal_ptp(0.5, 0.02, 0.6, Signature::shading, 3.0) ==
        doctest::Approx(4 / kPi * 0.5 * 0.02 * 0.6 * 2 * kPi * 3.0));
  // The noise that counts sits halfway between bar and gap for albedo.
  CHECK(element_mean_level(-0.9, 0.8, Signature::albedo) == doctest::Approx(0.44));
  CHECK(element_mean_level(0.02, 0.6, Signature::shading) == doctest::Approx(0.6));
  // Nothing non-finite comes out.
  CHECK(rose_cnr(1.0, 80.0, 0.0) == 0.0);
  CHECK(bar_signal_ptp(std::nan(""), -0.9, 0.8, Signature::albedo, 1.0) == 0.0);
}

TEST_CASE("the detectability limit sits where the CNR crosses k") {
  const double sigma_mm = 0.02, px_per_mm = 40, noise = 0.05;
  const Limit L = find_detectability_limit(cnr_series(sigma_mm, px_per_mm, noise), {});
  REQUIRE(L.any_resolved);
  REQUIRE(L.interpolated_lp_per_mm);
  // The true crossing, by bisection on the model itself.
  double lo = L.lp_per_mm, hi = 2 * L.lp_per_mm;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (gaussian_cnr(mid, sigma_mm, px_per_mm, noise) >= 5.0 ? lo : hi) = mid;
  }
  CHECK(gaussian_cnr(L.lp_per_mm, sigma_mm, px_per_mm, noise) >= 5.0);
  CHECK(*L.interpolated_lp_per_mm == doctest::Approx(lo).epsilon(1e-3));
  // Four times the noise: the limit moves down, and by more than an element.
  const Limit noisier = find_detectability_limit(cnr_series(sigma_mm, px_per_mm, 4 * noise), {});
  REQUIRE(noisier.interpolated_lp_per_mm);
  CHECK(*noisier.interpolated_lp_per_mm < *L.interpolated_lp_per_mm / std::exp2(1.0 / 6));
}

TEST_CASE("an undetectable element ends the chain, an unmeasured one is bridged") {
  std::vector<CnrPoint> pts = {{0, 1, 1.0, 40, 1}, {0, 2, 1.12, 30, 1}, {0, 3, 1.26, 20, 1}, {0, 4, 1.41, 3, 1}};
  pts[1].usable = false;
  pts[1].unmeasured = true;
  Limit L = find_detectability_limit(pts, {});
  CHECK(L.element == 3);
  REQUIRE(L.bridged.size() == 1);
  CHECK(L.bridged[0].element == 2);
  pts[1].unmeasured = false;  // graded (e.g. low_signal): never detectable
  L = find_detectability_limit(pts, {});
  CHECK(L.element == 1);
  // CNR above k but not significantly above zero: not detectable.
  pts = {{0, 1, 1.0, 6, 4}};
  CHECK_FALSE(find_detectability_limit(pts, {}).any_resolved);
  // Unless the bars' gaps show them (chart photographs); below k still not.
  pts[0].shown_by_dips = true;
  CHECK(find_detectability_limit(pts, {}).any_resolved);
  pts[0].cnr = 4;
  CHECK_FALSE(find_detectability_limit(pts, {}).any_resolved);
}

TEST_CASE("the reported limit is the coarser one and says which") {
  Limit optics, noise;
  optics.any_resolved = noise.any_resolved = true;
  optics.lp_per_mm = 7.13;
  optics.interpolated_lp_per_mm = 7.5;
  noise.lp_per_mm = 6.35;
  noise.interpolated_lp_per_mm = 6.9;
  LimitBreakdown b = combine_limits(optics, noise);
  CHECK(b.limited_by == LimitingFactor::light_noise);
  CHECK(b.reported().lp_per_mm == 6.35);
  noise.lp_per_mm = 7.13;  // the same element: the interpolated value decides
  CHECK(combine_limits(optics, noise).limited_by == LimitingFactor::light_noise);
  noise.interpolated_lp_per_mm = 7.8;
  CHECK(combine_limits(optics, noise).limited_by == LimitingFactor::optics);
  noise.interpolated_lp_per_mm = 7.5;  // a tie goes to the optics
  CHECK(combine_limits(optics, noise).limited_by == LimitingFactor::optics);
  noise.any_resolved = false;  // nothing detectable
  b = combine_limits(optics, noise);
  CHECK(b.limited_by == LimitingFactor::light_noise);
  const nlohmann::json j = breakdown_to_json(b, {});
  CHECK(j["limited_by"] == "light/noise");
  CHECK(j["resolved_any"] == false);
  CHECK(j["optical"]["lp_per_mm"] == 7.13);
  CHECK(j["detectability"]["k"] == 5.0);
}

TEST_CASE("the detectability criterion validates itself") {
  CHECK_THROWS_AS((DetectabilityCriterion{0.5, 2}.validate()), std::invalid_argument);
  CHECK_THROWS_AS((DetectabilityCriterion{std::nan(""), 2}.validate()), std::invalid_argument);
  CHECK_NOTHROW(DetectabilityCriterion{}.validate());
}

TEST_CASE("light needed: the exposure factor that brings the CNR to k") {
  // Shot noise only: CNR grows as sqrt(exposure).
  CHECK(exposure_factor_for_cnr(2.5, 1.0, 5.0) == doctest::Approx(4.0));
  // Read noise only: CNR grows as the exposure.
  CHECK(exposure_factor_for_cnr(2.5, 0.0, 5.0) == doctest::Approx(2.0));
  // Light to spare: below 1, and mixed noise lies between the two laws.
  const double g = exposure_factor_for_cnr(10.0, 0.5, 5.0);
  CHECK(g < 1.0);
  CHECK(g > 0.25);
  CHECK(g < 0.5);
  CHECK(exposure_factor_for_cnr(0.0, 0.5, 5.0) == 0.0);
  // At the optical limit G0E3 (interpolated between E3 and E4).
  std::vector<CnrPoint> pts = {{0, 1, 1.0, 40, 1}, {0, 2, 1.12, 30, 1}, {0, 3, 1.26, 10, 1}, {0, 4, 1.41, 2.5, 1}};
  for (CnrPoint& p : pts) p.shot_fraction = 1.0;
  Limit optical;
  optical.any_resolved = true;
  optical.group = 0;
  optical.element = 3;
  optical.lp_per_mm = 1.26;
  CHECK(*light_needed_factor(pts, optical, {}) == doctest::Approx(0.25));  // CNR 10 at the discrete limit
  optical.interpolated_lp_per_mm = 1.41;
  CHECK(*light_needed_factor(pts, optical, {}) == doctest::Approx(4.0));   // CNR 2.5 at the next element
  optical.any_resolved = false;
  CHECK_FALSE(light_needed_factor(pts, optical, {}).has_value());
}
