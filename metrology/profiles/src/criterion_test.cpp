#include <cmath>
#include <numbers>
#include <stdexcept>

#include <doctest/doctest.h>

#include "tactres/profiles/criterion.h"

using namespace tactres;

namespace {
std::vector<MPoint> gaussian_series(double sigma_mm, double m_sigma) {
  std::vector<MPoint> pts;
  for (int g = 0; g <= 4; ++g)
    for (int e = 1; e <= 6; ++e) {
      const double f = std::exp2(g + (e - 1) / 6.0);
      const double m = std::exp(-2 * std::numbers::pi * std::numbers::pi * sigma_mm * sigma_mm * f * f);
      pts.push_back({g, e, f, m, m_sigma, true});
    }
  return pts;
}
}  // namespace

TEST_CASE("interpolated limit is exact for a Gaussian MTF") {
  const double sigma_mm = 0.03;
  const Limit L = find_limit(gaussian_series(sigma_mm, 0.0), {});
  // exp(-2 pi^2 s^2 f^2) = 0.1  =>  f = sqrt(ln 10 / 2) / (pi s)
  const double f_true = std::sqrt(std::log(10.0) / 2) / (std::numbers::pi * sigma_mm);
  REQUIRE(L.interpolated_lp_per_mm);
  CHECK(*L.interpolated_lp_per_mm == doctest::Approx(f_true).epsilon(1e-9));
  CHECK(L.lp_per_mm <= f_true);
  CHECK(std::exp2(L.group + L.element / 6.0) > f_true);  // the next element is past it
}

TEST_CASE("uncertainty propagates from m_sigma and the significance rule bites") {
  const Limit L = find_limit(gaussian_series(0.03, 0.01), {});
  REQUIRE(L.uncertainty_lp_per_mm);
  CHECK(*L.uncertainty_lp_per_mm > 0);
  CHECK(*L.uncertainty_lp_per_mm < 0.5);

  Criterion c;
  std::vector<MPoint> pts = gaussian_series(0.03, 0.0);
  pts[2].m_sigma = pts[2].m;  // m is only one sigma above zero: not significant
  const Limit cut = find_limit(pts, c);
  CHECK(cut.element == 2);
  CHECK(cut.group == 0);
  CHECK_FALSE(cut.interpolated_lp_per_mm);  // the next one is not a clean crossing
}

TEST_CASE("bars shown by their gaps stand for the significance, never for the threshold") {
  Criterion c;
  MPoint p{2, 1, 4.0, 0.16, 0.10};  // 1.6 sigma: not significant by m_sigma
  CHECK_FALSE(is_resolved(p, c));
  p.shown_by_dips = true;
  CHECK(is_resolved(p, c));
  p.m = 0.09;  // below the threshold: the dips do not lift m
  CHECK_FALSE(is_resolved(p, c));
  p.m = 0.16;
  p.usable = false;  // a graded element stays unresolved
  CHECK_FALSE(is_resolved(p, c));
}

TEST_CASE("unusable elements are never resolved, all-resolved is flagged") {
  std::vector<MPoint> pts = gaussian_series(0.001, 0.0);
  CHECK(find_limit(pts, {}).beyond_finest);
  pts[0].usable = false;
  CHECK_FALSE(find_limit(pts, {}).any_resolved);
  Criterion bad;
  bad.threshold = 1.5;
  CHECK_THROWS_AS(bad.validate(), std::invalid_argument);
}
