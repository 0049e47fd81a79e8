#include <cmath>

#include <doctest/doctest.h>
#include <nlohmann/json.hpp>

#include "tactres/targets/layout.h"
#include "tactres/targets/layout_json.h"
#include "tactres/targets/usaf_series.h"

using namespace tactres;

TEST_CASE("USAF series: lp/mm, bar width and length follow 2^(g+(e-1)/6)") {
  CHECK(usaf_lp_per_mm(2, 6) == doctest::Approx(7.127).epsilon(1e-3 / 7.127));
  CHECK(usaf_lp_per_mm(3, 2) == doctest::Approx(8.980).epsilon(1e-3 / 8.980));
  CHECK(usaf_lp_per_mm(0, 1) == 1.0);
  CHECK(usaf_lp_per_mm(-2, 1) == 0.25);
  CHECK(usaf_bar_width_mm(2, 6) == doctest::Approx(1.0 / (2 * 7.127)).epsilon(1e-3));
  CHECK(usaf_bar_length_mm(1, 1) == doctest::Approx(5 * 0.25));
  CHECK_THROWS_AS(usaf_lp_per_mm(1, 7), std::invalid_argument);
}

TEST_CASE("default layout: every element follows the series") {
  const TargetLayout L = make_layout({});
  CHECK(L.elements.size() == 5 * 6 * 2);
  for (const ElementLayout& e : L.elements) {
    const double f = std::exp2(e.group + (e.element - 1) / 6.0);
    const double w = 1.0 / (2 * f);
    CHECK(e.lp_per_mm == doctest::Approx(f).epsilon(1e-12));
    CHECK(e.bar_width_mm == doctest::Approx(w).epsilon(1e-12));
    for (int i = 0; i < 3; ++i) {
      const RectMm& b = e.bars_mm[i];
      const bool horizontal = e.orientation == BarOrientation::horizontal_bars;
      const double across = horizontal ? b.height_mm() : b.width_mm();
      const double along = horizontal ? b.width_mm() : b.height_mm();
      CHECK(across == doctest::Approx(w).epsilon(1e-9));
      CHECK(along == doctest::Approx(5 * w).epsilon(1e-9));
      if (i > 0) {  // bars one width apart: pitch 2w
        const RectMm& p = e.bars_mm[i - 1];
        const double pitch = horizontal ? b.y0 - p.y0 : b.x0 - p.x0;
        CHECK(pitch == doctest::Approx(2 * w).epsilon(1e-9));
      }
    }
  }
  const ElementLayout* g2e6 = L.find(2, 6, BarOrientation::horizontal_bars);
  REQUIRE(g2e6);
  CHECK(std::abs(g2e6->lp_per_mm - 7.127) < 1e-3);
  const ElementLayout* g3e2 = L.find(3, 2, BarOrientation::vertical_bars);
  REQUIRE(g3e2);
  CHECK(std::abs(g3e2->lp_per_mm - 8.980) < 1e-3);
}

namespace {
double shape_distance(const ArtworkShape& a, const ArtworkShape& b) {
  // Conservative separation between bounds; discs use exact centre distance
  // against a rectangle's nearest point.
  auto rect_disc = [](const RectMm& r, Vec2 c, double rad) {
    const double dx = std::max({r.x0 - c.x, 0.0, c.x - r.x1});
    const double dy = std::max({r.y0 - c.y, 0.0, c.y - r.y1});
    return std::hypot(dx, dy) - rad;
  };
  using K = ArtworkShape::Kind;
  if (a.kind == K::disc && b.kind == K::disc)
    return norm(a.center_mm - b.center_mm) - a.radius_mm - b.radius_mm;
  if (a.kind == K::disc) return rect_disc(b.bounds_mm(), a.center_mm, a.radius_mm);
  if (b.kind == K::disc) return rect_disc(a.bounds_mm(), b.center_mm, b.radius_mm);
  const RectMm ra = a.bounds_mm(), rb = b.bounds_mm();
  const double dx = std::max({ra.x0 - rb.x1, rb.x0 - ra.x1});
  const double dy = std::max({ra.y0 - rb.y1, rb.y0 - ra.y1});
  if (dx <= 0 && dy <= 0) return -std::min(-dx, -dy);  // overlap depth
  return std::hypot(std::max(dx, 0.0), std::max(dy, 0.0));
}
}  // namespace

TEST_CASE("default layout: shapes inside the field, no overlaps, quiet zone around triplets") {
  const TargetLayout L = make_layout({});
  const RectMm field{0, 0, L.width_mm, L.height_mm};
  for (const ArtworkShape& s : L.artwork) CHECK(field.contains(s.bounds_mm()));
  for (size_t i = 0; i < L.artwork.size(); ++i)
    for (size_t k = i + 1; k < L.artwork.size(); ++k)
      CHECK(shape_distance(L.artwork[i], L.artwork[k]) >= -1e-12);

  // Each triplet's quiet zone (one bar width) holds nothing but its own bars.
  for (const ElementLayout& e : L.elements) {
    const RectMm zone = e.extent_mm().inflated(kQuietZoneBarWidths * e.bar_width_mm * (1 - 1e-9));
    for (const ArtworkShape& s : L.artwork) {
      bool own = false;
      for (const RectMm& b : e.bars_mm)
        own = own || (s.kind == ArtworkShape::Kind::rect && s.rect_mm.overlap_area_mm2(b) > 0);
      if (!own) CHECK(zone.overlap_area_mm2(s.bounds_mm()) == 0.0);
    }
  }
  CHECK(L.fiducials.size() == 5);
  CHECK(L.reference_patch_mm.area_mm2() > 4.0);
}

TEST_CASE("layout options validate themselves") {
  LayoutOptions o;
  o.first_group = 3;
  o.last_group = 2;
  CHECK_THROWS_WITH_AS(o.validate(), doctest::Contains("inverted"), std::invalid_argument);
  o = {};
  o.field_width_mm = -1;
  CHECK_THROWS_AS(o.validate(), std::invalid_argument);
  o = {};
  o.relief_height_mm = 0;
  CHECK_THROWS_AS(o.validate(), std::invalid_argument);
  o = {};
  o.first_group = -2;  // group -2 bars are 2 mm wide: they need a bigger field
  CHECK_THROWS_WITH_AS(make_layout(o), doctest::Contains("field of"), std::invalid_argument);
}

TEST_CASE("layout JSON round-trips") {
  LayoutOptions o;
  o.polarity = Polarity::light_bars_on_dark;
  o.relief_height_mm = 0.25;
  const TargetLayout a = make_layout(o);
  const nlohmann::json j = layout_to_json(a);
  CHECK(j["schema"] == "tactres.target/1");
  const TargetLayout b = layout_from_json(nlohmann::json::parse(j.dump()));
  CHECK(layout_to_json(b) == j);
  CHECK(b.polarity == Polarity::light_bars_on_dark);
  CHECK(b.relief_height_mm == 0.25);
  REQUIRE(b.artwork.size() == a.artwork.size());
  CHECK(b.inked_area_mm2() == doctest::Approx(a.inked_area_mm2()).epsilon(1e-12));
}

TEST_CASE("layout JSON reader names the bad field") {
  nlohmann::json j = layout_to_json(make_layout({}));
  j["elements"][3]["bars_mm"][1] = {1, 2, 0, 3};
  CHECK_THROWS_WITH_AS(layout_from_json(j), doctest::Contains("elements[3].bars_mm[1]"),
                       std::invalid_argument);
  j = layout_to_json(make_layout({}));
  j["schema"] = "tactres.target/0";
  CHECK_THROWS_WITH_AS(layout_from_json(j), doctest::Contains("schema"), std::invalid_argument);
  CHECK_THROWS_AS(parse_json_text("{\"schema\": ", "x.json"), std::invalid_argument);
}

TEST_CASE("layout JSON reader refuses unknown fields and numbers that disagree with the bars") {
  const nlohmann::json good = layout_to_json(make_layout({}));
  const auto refused = [](const nlohmann::json& j, const char* says) {
    try {
      layout_from_json(j);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what()).find(says) != std::string::npos;
    }
    return false;
  };
  nlohmann::json j = good;
  j["colour"] = "red";
  CHECK(refused(j, "layout has unknown field(s) colour"));
  j = good;
  j["elements"][2]["note"] = 1;
  CHECK(refused(j, "layout.elements[2] has unknown field(s) note"));
  j = good;
  j["fiducials"][0]["size"] = 1;
  CHECK(refused(j, "layout.fiducials[0] has unknown field(s) size"));
  j = good;
  j["elements"][0]["lp_per_mm"] = 3.0;  // its bars are still the series' width
  CHECK(refused(j, "layout.elements[0].lp_per_mm 3 is not group"));
  j = good;
  j["elements"][0]["bar_width_mm"] = 0.4;
  CHECK(refused(j, "layout.elements[0].bar_width_mm 0.4 is not half a line pair"));
  j = good;
  j["elements"].push_back(j["elements"][4]);
  CHECK(refused(j, "repeats layout.elements[4]"));
  j = good;
  j["size_mm"] = {1e-9, 1e-9};
  CHECK(refused(j, "lies outside the target's size_mm"));
  j = good;
  j["groups"] = {4, 0};
  CHECK(refused(j, "layout.groups [4, 0] does not match its elements' groups 0..4"));
  CHECK_NOTHROW(layout_from_json(good));
}
