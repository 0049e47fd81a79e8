#include <cmath>
#include <map>

#include <doctest/doctest.h>
#include <nlohmann/json.hpp>

#include "tactres/targets/raster.h"
#include "tactres/targets/layout_json.h"
#include "tactres/targets/mil_std_chart.h"
#include "tactres/targets/usaf_series.h"

using namespace tactres;

namespace {
Vec2 centre(const TargetLayout& L, int g, int e, BarOrientation o) {
  const ElementLayout* el = L.find(g, e, o);
  REQUIRE(el);
  return el->extent_mm().center_mm();
}
}  // namespace

TEST_CASE("MIL-STD-150A chart: groups -2..7, every element follows the series, no fiducials") {
  const TargetLayout L = make_mil_std_chart({});
  CHECK(L.first_group == -2);
  CHECK(L.last_group == 7);
  CHECK(L.elements.size() == 10 * 6 * 2);
  CHECK(L.fiducials.empty());
  for (const ElementLayout& e : L.elements) {
    const double f = std::exp2(e.group + (e.element - 1) / 6.0);
    CHECK(e.lp_per_mm == doctest::Approx(f).epsilon(1e-12));
    CHECK(e.bar_width_mm == doctest::Approx(0.5 / f).epsilon(1e-12));
    const bool horizontal = e.orientation == BarOrientation::horizontal_bars;
    for (int i = 0; i < 3; ++i) {
      const RectMm& b = e.bars_mm[i];
      CHECK((horizontal ? b.height_mm() : b.width_mm()) == doctest::Approx(e.bar_width_mm).epsilon(1e-9));
      CHECK((horizontal ? b.width_mm() : b.height_mm()) == doctest::Approx(5 * e.bar_width_mm).epsilon(1e-9));
    }
  }
  // Group -2 element 1: 0.25 lp/mm, 2 mm bars; the chart is some 9 x 7 cm.
  CHECK(L.width_mm == doctest::Approx(44 * 2.0).epsilon(0.05));
  CHECK(L.height_mm > 55);
  CHECK(L.height_mm < 75);
  // The large square is the reference patch: 5 W of the outermost pair.
  CHECK(L.reference_patch_mm.width_mm() == doctest::Approx(10.0));
}

TEST_CASE("MIL-STD-150A chart: no overlaps, one bar width of quiet zone around every triplet") {
  const TargetLayout L = make_mil_std_chart({});
  const RectMm field{0, 0, L.width_mm, L.height_mm};
  for (const ArtworkShape& s : L.artwork) CHECK(field.contains(s.bounds_mm()));
  // Shapes never overlap (the emitters and the coverage model rely on it).
  for (size_t i = 0; i < L.artwork.size(); ++i)
    for (size_t k = i + 1; k < L.artwork.size(); ++k)
      if (L.artwork[i].bounds_mm().overlap_area_mm2(L.artwork[k].bounds_mm()) > 0) {
        FAIL_CHECK("artwork " << i << " overlaps artwork " << k);
      }
  for (const ElementLayout& e : L.elements) {
    const RectMm zone = e.extent_mm().inflated(1.5 * e.bar_width_mm * (1 - 1e-9));
    for (const ArtworkShape& s : L.artwork) {
      bool own = false;
      for (const RectMm& b : e.bars_mm) own = own || s.rect_mm.overlap_area_mm2(b) > 0;
      if (!own && zone.overlap_area_mm2(s.bounds_mm()) > 0)
        FAIL_CHECK("group " << e.group << " element " << e.element << " has a shape in its quiet zone");
    }
  }
}

TEST_CASE("MIL-STD-150A chart: the standard arrangement") {
  const TargetLayout L = make_mil_std_chart({});
  const auto H = BarOrientation::horizontal_bars, V = BarOrientation::vertical_bars;
  for (int g = -2; g <= 6; g += 2) {
    // Odd group: elements 1..6 down one column on the right, from the top.
    for (int e = 2; e <= 6; ++e) {
      CHECK(centre(L, g + 1, e, H).y > centre(L, g + 1, e - 1, H).y);
      CHECK(std::abs(L.find(g + 1, e, H)->bars_mm[0].x0 - L.find(g + 1, 1, H)->bars_mm[0].x0) <
            3 * L.find(g + 1, 1, H)->bar_width_mm);
    }
    // Even group: 2..6 down the left column; element 1 at the lower right,
    // right of and below every other element of the pair.
    for (int e = 3; e <= 6; ++e) CHECK(centre(L, g, e, H).y > centre(L, g, e - 1, H).y);
    const Vec2 e1 = centre(L, g, 1, V);
    for (int e = 2; e <= 6; ++e) CHECK(e1.x > centre(L, g, e, V).x);
    for (int e = 1; e <= 6; ++e) CHECK(e1.y > centre(L, g + 1, e, H).y);
    CHECK(centre(L, g + 1, 1, V).x > centre(L, g, 2, V).x);
    // Within an element: the H triplet left of the V triplet, same row.
    for (int e = 1; e <= 6; ++e) {
      CHECK(centre(L, g, e, H).x < centre(L, g, e, V).x);
      CHECK(centre(L, g, e, H).y == doctest::Approx(centre(L, g, e, V).y));
    }
    // The next pair spirals inward: inside the columns of this one.
    if (g + 2 <= 7) {
      const Vec2 inner = centre(L, g + 2, 1, H);
      CHECK(inner.x > centre(L, g, 2, V).x);
      CHECK(inner.x < centre(L, g + 1, 1, H).x);
      CHECK(inner.y < e1.y);
    }
  }
}

TEST_CASE("MIL-STD-150A chart: sub-ranges, odd first group, validation, JSON without fiducials") {
  MilStdChartOptions o;
  o.first_group = 1;
  o.last_group = 4;
  const TargetLayout L = make_mil_std_chart(o);
  CHECK(L.elements.size() == 4 * 6 * 2);
  CHECK(L.find(0, 1, BarOrientation::horizontal_bars) == nullptr);
  CHECK(L.find(1, 1, BarOrientation::horizontal_bars) != nullptr);
  CHECK(L.reference_patch_mm.area_mm2() > 0);
  const nlohmann::json j = layout_to_json(L);
  CHECK(j["fiducials"].empty());
  const TargetLayout back = layout_from_json(nlohmann::json::parse(j.dump()));
  CHECK(layout_to_json(back) == j);
  // The raster emitter covers it (exact area coverage: inked area preserved).
  const ImageF cov = coverage_raster(L, 20.0);
  double inked = 0;
  for (float v : cov.pixels) inked += v;
  CHECK(inked / (20.0 * 20.0) == doctest::Approx(L.inked_area_mm2()).epsilon(1e-3));

  o.first_group = 3;
  o.last_group = 2;
  CHECK_THROWS_WITH_AS(o.validate(), doctest::Contains("inverted"), std::invalid_argument);
  o = {};
  o.last_group = 13;
  CHECK_THROWS_AS(make_mil_std_chart(o), std::invalid_argument);
}
