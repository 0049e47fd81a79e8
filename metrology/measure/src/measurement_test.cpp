// MeasureOptions: the presets' profile bins per element (bin_px_for).

#include <doctest/doctest.h>

#include "tactres/measure/measurement.h"

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
