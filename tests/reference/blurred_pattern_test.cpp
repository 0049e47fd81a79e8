// Unit tests of the analytic blurred pattern and the shape decomposition.
#include <cmath>
#include <random>

#include <doctest/doctest.h>

#include "reference_renderer.h"

using namespace reference;

TEST_CASE("renderer: a blurred rectangle integrates to its area") {
  const RectMm r{1.0, 2.0, 1.7, 2.3};
  for (double sigma_mm : {0.02, 0.1, 0.3}) {
    const double step_mm = 0.005;
    double sum = 0;
    for (double y = 0; y < 5; y += step_mm)
      for (double x = -1; x < 4; x += step_mm) sum += blurred_rect(r, sigma_mm, x + 0.5 * step_mm, y + 0.5 * step_mm);
    CAPTURE(sigma_mm);
    CHECK(sum * step_mm * step_mm == doctest::Approx(0.7 * 0.3).epsilon(1e-6));
  }
}

TEST_CASE("renderer: far from every edge the pattern is the plain indicator") {
  const BlurredPattern p({{0, 0, 4, 4}, {5, 0, 6, 1}}, 0.05);
  CHECK(p.coverage(2, 2) == 1.0);   // deep inside
  CHECK(p.coverage(4.5, 3) == 0.0);  // between shapes, > 7 sigma from both
  CHECK(p.coverage(-3, -3) == 0.0);  // outside the grid
  CHECK(p.coverage(4, 2) == doctest::Approx(0.5).epsilon(1e-12));  // on a straight edge
  CHECK(p.coverage(0, 0) == doctest::Approx(0.25).epsilon(1e-12));  // at a corner
}

TEST_CASE("renderer: culled evaluation equals the brute-force sum, gradient equals finite differences") {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, 3);
  std::vector<RectMm> rects;
  for (int i = 0; i < 30; ++i) {  // a row of disjoint bars of varying width
    const double x0 = 0.1 * i;
    rects.push_back({x0, 0.5, x0 + 0.02 + 0.002 * i, 0.5 + 0.3 + 0.05 * (i % 4)});
  }
  const double sigma_mm = 0.03;
  const BlurredPattern p(rects, sigma_mm);
  for (int k = 0; k < 200; ++k) {
    const double x = u(rng), y = 0.3 + 0.4 * u(rng) / 3 * 2;
    double brute = 0;
    for (const RectMm& r : rects) brute += blurred_rect(r, sigma_mm, x, y);
    CHECK(p.coverage(x, y) == doctest::Approx(brute).epsilon(1e-9));
    const double h = 1e-5;
    const Vec2 g = p.coverage_gradient_per_mm(x, y);
    CHECK(g[0] == doctest::Approx((p.coverage(x + h, y) - p.coverage(x - h, y)) / (2 * h)).epsilon(1e-5).scale(1));
    CHECK(g[1] == doctest::Approx((p.coverage(x, y + h) - p.coverage(x, y - h)) / (2 * h)).epsilon(1e-5).scale(1));
  }
}

TEST_CASE("renderer: disc strips keep the disc's area and extent, polygon strips the polygon's area") {
  const auto strips = disc_strips({3, 4}, 0.6, 96);
  CHECK(strips.size() == 96);
  double area_mm2 = 0;
  for (const RectMm& s : strips) area_mm2 += (s.x1_mm - s.x0_mm) * (s.y1_mm - s.y0_mm);
  CHECK(area_mm2 == doctest::Approx(M_PI * 0.36).epsilon(1e-12));
  CHECK(strips.front().y0_mm == doctest::Approx(3.4));
  CHECK(strips.back().y1_mm == doctest::Approx(4.6));

  // A right triangle with legs 2 mm: area 2 mm^2; and an L (non-convex).
  double tri_mm2 = 0;
  for (const RectMm& s : polygon_strips({{0, 0}, {2, 2}, {0, 2}}, 0.005))
    tri_mm2 += (s.x1_mm - s.x0_mm) * (s.y1_mm - s.y0_mm);
  CHECK(tri_mm2 == doctest::Approx(2.0).epsilon(1e-9));
  double l_mm2 = 0;
  for (const RectMm& s : polygon_strips({{0, 0}, {1, 0}, {1, 2}, {3, 2}, {3, 3}, {0, 3}}, 0.01))
    l_mm2 += (s.x1_mm - s.x0_mm) * (s.y1_mm - s.y0_mm);
  CHECK(l_mm2 == doctest::Approx(5.0).epsilon(1e-9));
}

TEST_CASE("renderer: a blurred disc made of strips matches the disc's radial profile") {
  // The Gaussian-blurred disc at its centre: 1 - exp(-r^2 / (2 sigma^2)).
  const double r_mm = 0.6, sigma_mm = 0.05;
  const BlurredPattern p(disc_strips({0, 0}, r_mm, 96), sigma_mm);
  CHECK(p.coverage(0, 0) == doctest::Approx(1 - std::exp(-r_mm * r_mm / (2 * sigma_mm * sigma_mm))).epsilon(1e-9));
  // On the rim the value is ~0.5 (slightly less: the edge curves away), in every direction.
  for (double a_deg : {0.0, 30.0, 45.0, 90.0}) {
    const double a = a_deg * M_PI / 180;
    CAPTURE(a_deg);
    CHECK(p.coverage(r_mm * std::cos(a), r_mm * std::sin(a)) == doctest::Approx(0.48).epsilon(0.02));
  }
}
