#include "tactres/simulate/effects/illumination.h"

#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <doctest/doctest.h>

using namespace tactres;

namespace {

constexpr double kPi = std::numbers::pi;

// Gauss-Legendre nodes and weights on [-1, 1] (Newton on P_n).
struct GaussLegendre {
  std::vector<double> x, w;
  explicit GaussLegendre(int n) {
    for (int i = 0; i < n; ++i) {
      double z = std::cos(kPi * (i + 0.75) / (n + 0.5));
      double dp = 0.0;
      for (int it = 0; it < 100; ++it) {
        double p0 = 1.0, p1 = z;
        for (int k = 2; k <= n; ++k) {
          const double p2 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p0) / k;
          p0 = p1;
          p1 = p2;
        }
        dp = n * (z * p1 - p0) / (z * z - 1.0);
        const double dz = p1 / dp;
        z -= dz;
        if (std::abs(dz) < 1e-15) break;
      }
      x.push_back(z);
      w.push_back(2.0 / ((1.0 - z * z) * dp * dp));
    }
  }
};

// Composite Gauss-Legendre over [a, b]: `panels` panels of the rule.
template <class F>
double integrate(F f, double a, double b, int panels, const GaussLegendre& rule) {
  double sum = 0.0;
  const double h = (b - a) / panels;
  for (int p = 0; p < panels; ++p) {
    const double mid = a + (p + 0.5) * h;
    for (std::size_t i = 0; i < rule.x.size(); ++i) sum += rule.w[i] * f(mid + 0.5 * h * rule.x[i]);
  }
  return 0.5 * h * sum;
}

// The configuration factor by brute-force quadrature of (1/pi) d^2 / r^4 over
// the aperture: an independent check of the closed forms.
double quadrature_factor(const IlluminationOptions& o, Vec2 p) {
  static const GaussLegendre rule(10);
  const double d2 = o.distance_mm * o.distance_mm;
  auto kernel = [&](double x, double y) {
    const double r2 = (x - p.x) * (x - p.x) + (y - p.y) * (y - p.y) + d2;
    return d2 / (r2 * r2);
  };
  const Vec2 c = o.aperture_center_mm;
  const int panels = 48;
  double total;
  if (o.shape == IlluminationOptions::circle) {
    const double radius = 0.5 * o.aperture_width_mm;
    total = integrate(
        [&](double r) {
          return r * integrate(
                         [&](double phi) {
                           return kernel(c.x + r * std::cos(phi), c.y + r * std::sin(phi));
                         },
                         0.0, 2 * kPi, panels, rule);
        },
        0.0, radius, panels, rule);
  } else {
    const double hw = 0.5 * o.aperture_width_mm;
    const double hh =
        0.5 * (o.shape == IlluminationOptions::square ? o.aperture_width_mm : o.aperture_height_mm);
    total = integrate(
        [&](double x) {
          return integrate([&](double y) { return kernel(x, y); }, c.y - hh, c.y + hh, panels, rule);
        },
        c.x - hw, c.x + hw, panels, rule);
  }
  return total / kPi;
}

IlluminationOptions aperture(IlluminationOptions::Shape shape, double w, double h, double d) {
  IlluminationOptions o;
  o.shape = shape;
  o.aperture_width_mm = w;
  o.aperture_height_mm = h;
  o.distance_mm = d;
  o.aperture_center_mm = {10.0, 10.0};
  return o;
}

}  // namespace

TEST_CASE("aperture_view_factor: coaxial disc and small-source limits") {
  for (double d : {0.5, 2.0, 10.0, 18.0, 100.0}) {
    const IlluminationOptions o = aperture(IlluminationOptions::circle, 15.0, 0.0, d);
    const double r = 7.5;
    CAPTURE(d);
    CHECK(aperture_view_factor(o, o.aperture_center_mm) ==
          doctest::Approx(r * r / (r * r + d * d)).epsilon(1e-14));
  }
  // Far from the aperture it acts as a point source: F -> A d^2 / (pi r^4),
  // with a relative correction of order (size / r)^2.
  for (auto shape : {IlluminationOptions::circle, IlluminationOptions::square,
                     IlluminationOptions::rectangle}) {
    const IlluminationOptions o = aperture(shape, 15.0, 33.0, 18.0);
    const double area = shape == IlluminationOptions::circle ? kPi * 7.5 * 7.5
                        : shape == IlluminationOptions::square ? 15.0 * 15.0
                                                               : 15.0 * 33.0;
    double previous = 1.0;
    for (double rho : {300.0, 1000.0, 3000.0}) {
      const Vec2 p{10.0 + rho * 0.6, 10.0 - rho * 0.8};
      const double r2 = rho * rho + 18.0 * 18.0;
      const double point_source = area * 18.0 * 18.0 / (kPi * r2 * r2);
      const double rel = std::abs(aperture_view_factor(o, p) / point_source - 1.0);
      const std::string name = to_string(shape);
      CAPTURE(name);
      CAPTURE(rho);
      CHECK(rel < 10.0 * (33.0 / rho) * (33.0 / rho));
      CHECK(rel < previous);  // converges
      previous = rel;
    }
  }
  // An infinite emitter fills the hemisphere: F -> 1.
  CHECK(aperture_view_factor(aperture(IlluminationOptions::square, 1000.0, 0.0, 1.0), {10, 10}) ==
        doctest::Approx(1.0).epsilon(1e-5));
  CHECK(aperture_view_factor(aperture(IlluminationOptions::circle, 1000.0, 0.0, 1.0), {10, 10}) ==
        doctest::Approx(1.0).epsilon(1e-5));
}

TEST_CASE("aperture_view_factor: closed forms match brute-force quadrature") {
  double worst = 0.0;
  for (auto shape : {IlluminationOptions::circle, IlluminationOptions::square,
                     IlluminationOptions::rectangle})
    for (double d : {2.0, 10.0, 18.0}) {
      const IlluminationOptions o = aperture(shape, 15.0, 33.0, d);
      // On axis, inside, on and near the rim / edges and corners, outside.
      for (Vec2 off : {Vec2{0, 0}, Vec2{3, -2}, Vec2{7.5, 0}, Vec2{0, -7.5}, Vec2{7.4, 16.4},
                       Vec2{-7.6, 16.6}, Vec2{5.3, 5.3}, Vec2{12, 4}, Vec2{-20, 25},
                       Vec2{40, -3}}) {
        const Vec2 p = o.aperture_center_mm + off;
        const double closed = aperture_view_factor(o, p);
        const double numeric = quadrature_factor(o, p);
        const std::string name = to_string(shape);
        CAPTURE(name);
        CAPTURE(d);
        CAPTURE(off.x);
        CAPTURE(off.y);
        CHECK(closed == doctest::Approx(numeric).epsilon(1e-8));
        worst = std::max(worst, std::abs(closed / numeric - 1.0));
      }
    }
  MESSAGE("closed-form vs quadrature view factor, worst relative difference: " << worst);

  // A rectangle's width runs along target x.
  const IlluminationOptions wide = aperture(IlluminationOptions::rectangle, 33.0, 15.0, 10.0);
  CHECK(aperture_view_factor(wide, {22.0, 10.0}) > aperture_view_factor(wide, {10.0, 22.0}));
  CHECK(aperture_view_factor(wide, {22.0, 10.0}) ==
        doctest::Approx(aperture_view_factor(wide, {-2.0, 10.0})).epsilon(1e-14));
  // A square ignores aperture_height_mm.
  CHECK(aperture_view_factor(aperture(IlluminationOptions::square, 15.0, 99.0, 10.0), {3, 4}) ==
        aperture_view_factor(aperture(IlluminationOptions::square, 15.0, 15.0, 10.0), {3, 4}));
}

TEST_CASE("IlluminationField: normalisation, grid accuracy, hot spots") {
  struct Case {
    std::string name;
    IlluminationOptions options;
  };
  IlluminationOptions t1c1 = aperture(IlluminationOptions::circle, 15.0, 15.0, 18.0);
  IlluminationOptions t2c4 = aperture(IlluminationOptions::rectangle, 15.0, 33.0, 10.0);
  t2c4.aperture_center_mm = {11.0, 9.0};
  t2c4.gain = 1.7;
  IlluminationOptions t1c2_hot = aperture(IlluminationOptions::square, 15.0, 15.0, 18.0);
  t1c2_hot.hot_spots = {{{6.0, 7.0}, 1.5, 0.8}, {{15.0, 12.0}, 0.4, 2.0}};
  IlluminationOptions t1c1_leds = t1c1;
  t1c1_leds.hot_spots = {{{5.0, 8.0}, 2.5, 0.6}, {{15.0, 8.0}, 2.5, 0.6}};
  IlluminationOptions close = aperture(IlluminationOptions::circle, 15.0, 15.0, 2.0);
  const std::vector<Case> cases = {{"T1C1", t1c1},
                                   {"T2C4 off-centre, gain 1.7", t2c4},
                                   {"T1C2 narrow hot spot (analytic)", t1c2_hot},
                                   {"T1C1 LED hot spots (gridded)", t1c1_leds},
                                   {"circle at 2 mm", close}};
  const RectMm domain{-2.0, -2.0, 22.0, 22.0};
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> ux(domain.x0, domain.x1), uy(domain.y0, domain.y1);
  double worst = 0.0;
  for (const Case& c : cases) {
    const IlluminationField field(c.options, domain);
    CAPTURE(c.name);
    // The foot point reads `gain` before hot spots.
    if (c.options.hot_spots.empty()) {
      CHECK(field.exact_relative_irradiance(c.options.aperture_center_mm) ==
            doctest::Approx(c.options.gain).epsilon(1e-15));
      CHECK(field.relative_irradiance(c.options.aperture_center_mm) ==
            doctest::Approx(c.options.gain).epsilon(1e-4));
    }
    CHECK(field.measured_grid_error() < 1e-4);
    // Wide hot spots share the grid; a 0.4 mm one would need ~7 M nodes.
    CHECK(field.grid_includes_hot_spots() == (&c.options == &cases[3].options));
    double case_worst = 0.0;
    for (int i = 0; i < 20000; ++i) {
      const Vec2 p{ux(rng), uy(rng)};
      const double exact = field.exact_relative_irradiance(p);
      case_worst = std::max(case_worst, std::abs(field.relative_irradiance(p) - exact) / exact);
    }
    CHECK(case_worst < 1e-4);
    worst = std::max(worst, case_worst);
    MESSAGE(c.name << ": grid " << field.grid_columns() << " x " << field.grid_rows() << ", step "
                   << field.grid_step_mm() << " mm, worst relative error at 20000 random points "
                   << case_worst);
    // Outside the domain the closed form is used.
    for (Vec2 p : {Vec2{-30.0, 5.0}, Vec2{40.0, 40.0}})
      CHECK(field.relative_irradiance(p) == field.exact_relative_irradiance(p));
  }
  MESSAGE("IlluminationField worst grid error over all cases: " << worst);

  // Hot spots add gain * peak at their centre and nothing beyond 6 sigma.
  IlluminationOptions hot = t1c1;
  hot.gain = 2.0;
  hot.hot_spots = {{{4.0, 5.0}, 1.0, 0.5}};
  const IlluminationField plain(t1c1, domain), with_spot(hot, domain);
  CHECK(with_spot.exact_relative_irradiance({4.0, 5.0}) ==
        doctest::Approx(2.0 * (plain.exact_relative_irradiance({4.0, 5.0}) + 0.5)));
  CHECK(with_spot.exact_relative_irradiance({4.0, 5.0 + 1.0}) ==
        doctest::Approx(2.0 * (plain.exact_relative_irradiance({4.0, 6.0}) + 0.5 * std::exp(-0.5))));
  CHECK(with_spot.exact_relative_irradiance({4.0, 12.0}) ==
        doctest::Approx(2.0 * plain.exact_relative_irradiance({4.0, 12.0})).epsilon(1e-15));

  // The field falls off away from the foot point, and faster for a nearer
  // aperture (T2 at 10 mm against T1 at 18 mm), whose kernel is narrower.
  const IlluminationField far(aperture(IlluminationOptions::circle, 15.0, 0.0, 18.0), domain);
  const IlluminationField near(aperture(IlluminationOptions::circle, 15.0, 0.0, 10.0), domain);
  CHECK(far.exact_relative_irradiance({0.0, 10.0}) < 1.0);
  CHECK(near.exact_relative_irradiance({0.0, 10.0}) < far.exact_relative_irradiance({0.0, 10.0}));
}

TEST_CASE("IlluminationOptions / IlluminationField: validation") {
  CHECK_NOTHROW(IlluminationOptions{}.validate());
  auto throws_mentioning = [](const IlluminationOptions& o, const std::string& text) {
    try {
      o.validate();
      return false;
    } catch (const std::invalid_argument& e) {
      return std::string(e.what()).find(text) != std::string::npos;
    }
  };
  IlluminationOptions o;
  o.aperture_width_mm = 0.0;
  CHECK(throws_mentioning(o, "aperture_width_mm"));
  o = {};
  o.shape = IlluminationOptions::rectangle;
  o.aperture_height_mm = -1.0;
  CHECK(throws_mentioning(o, "aperture_height_mm"));
  o.shape = IlluminationOptions::circle;  // height unused by a circle
  CHECK_NOTHROW(o.validate());
  o = {};
  o.distance_mm = 0.1;
  CHECK(throws_mentioning(o, "[0.5, 1000]"));
  o = {};
  o.gain = 0.0;
  CHECK(throws_mentioning(o, "gain"));
  o = {};
  o.hot_spots = {{{1.0, 1.0}, 0.0, 1.0}};
  CHECK(throws_mentioning(o, "hot spot 0: sigma_mm"));
  o = {};
  o.hot_spots = {{{1.0, 1.0}, 1.0, 1.0}, {{1.0, 1.0}, 1.0, -1.0}};
  CHECK(throws_mentioning(o, "hot spot 1: peak_gain"));
  o = {};
  o.aperture_center_mm.x = std::nan("");
  CHECK(throws_mentioning(o, "aperture_center_mm"));

  for (auto s : {IlluminationOptions::circle, IlluminationOptions::square,
                 IlluminationOptions::rectangle})
    CHECK(illumination_shape_from_string(to_string(s)) == s);
  CHECK_THROWS_AS(illumination_shape_from_string("hexagon"), std::invalid_argument);

  CHECK_THROWS_AS(IlluminationField(IlluminationOptions{}, RectMm{0, 0, 0, 10}),
                  std::invalid_argument);
  CHECK_THROWS_AS(IlluminationField(IlluminationOptions{}, RectMm{0, 0, 10, 10}, 0.0),
                  std::invalid_argument);
  IlluminationOptions tiny_distance;
  tiny_distance.distance_mm = 0.5;
  try {
    IlluminationField(tiny_distance, RectMm{-500, -500, 500, 500});
    FAIL("no throw");
  } catch (const std::invalid_argument& e) {
    CHECK(std::string(e.what()).find("smaller domain") != std::string::npos);
  }
}
