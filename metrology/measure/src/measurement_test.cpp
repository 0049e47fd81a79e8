// MeasureOptions: the presets' profile bins per element (bin_px_for); the chart JSON's largest element;
// an element's place in the measurement JSON.

#include <doctest/doctest.h>

#include <nlohmann/json.hpp>

#include "tactres/locate/chart_detect.h"
#include "tactres/measure/measurement.h"
#include "tactres/measure/measurement_io.h"

using namespace tactres;

TEST_CASE("options: a profile bin is the preset's, capped per bar on coarse elements, and never over half a bar") {
  const MeasureOptions fast = MeasureOptions::for_preset(Preset::fast);
  const MeasureOptions balanced = MeasureOptions::for_preset(Preset::balanced);
  // Mid-sized elements: the preset's own bin.
  CHECK(fast.bin_px_for(4) == doctest::Approx(1.0));
  CHECK(balanced.bin_px_for(1.5) == doctest::Approx(0.25));
  // Coarse elements: no more than max_bins_per_bar bins per bar.
  CHECK(fast.bin_px_for(60) == doctest::Approx(60 / fast.max_bins_per_bar));
  CHECK(balanced.bin_px_for(60) == doctest::Approx(60 / balanced.max_bins_per_bar));
  // Near the sampling floor: at least two bins per bar, so whole-pixel
  // bins do not merge a bar's sub-pixel phases.
  CHECK(fast.bin_px_for(1.3) == doctest::Approx(0.65));
  CHECK(fast.bin_px_for(fast.min_px_per_bar) == doctest::Approx(0.5 * fast.min_px_per_bar));
}

TEST_CASE("chart JSON: largest_element is the element the indices count from, not a coarser placed partner") {
  ChartDetection D;
  D.found = true;
  D.patterns.resize(4);
  D.patterns[1].predicted = true;  // G-1E6's V triplet placed beside its found H triplet
  ChartElement placed, found;
  placed.h = 0, placed.v = 1, placed.relative_index = -1, placed.group = -1, placed.element = 6, placed.period_px = 44;
  found.h = 2, found.v = 3, found.relative_index = 0, found.group = 0, found.element = 1, found.period_px = 40;
  D.elements = {placed, found};
  REQUIRE(largest_found(D) == &D.elements[1]);
  const nlohmann::json j = chart_to_json(D);
  CHECK(j["largest_element"]["group"] == 0);
  CHECK(j["largest_element"]["element"] == 1);
  CHECK(j["largest_element"]["period_px"] == 40);
  D.elements.clear();
  CHECK(largest_found(D) == nullptr);
  CHECK_FALSE(chart_to_json(D).contains("largest_element"));
}

TEST_CASE("measurement JSON: an element's center_px is the middle of its strip, null where none was sampled in view") {
  Measurement m;
  m.usable = true;
  ElementResult sampled = ElementResult::of(3, 2, BarOrientation::vertical_bars, 8.98, 2.5);
  sampled.outline_px = {Vec2{10, 20}, Vec2{30, 20}, Vec2{30, 61}, Vec2{10, 61}};
  sampled.outline_valid = true;
  ElementResult outside = ElementResult::of(3, 3, BarOrientation::vertical_bars, 10.08, 2.2);
  outside.outline_px = sampled.outline_px;  // left from a strip out of view
  outside.status = ElementStatus::out_of_view;
  m.elements = {sampled, outside};
  const nlohmann::json j = measurement_to_json(m, MeasurementContext{});
  REQUIRE(j["elements"].size() == 2);
  CHECK(j["elements"][0]["center_px"] == nlohmann::json::array({20.0, 40.5}));
  CHECK(j["elements"][1]["center_px"].is_null());
}
