// The detectability limit (docs/CONVENTIONS.md, "Two limits") on the
// reference renderer's captures, against its own, independently written
// truth (truth.cpp, detectability_limit_lp_per_mm): grey printed bars under
// constant Gaussian noise (level step / 10, the "20 dB noise" case), with a
// strict Rose threshold k = 20 so that the noise, not the optics, limits.
#include <cmath>

#include <doctest/doctest.h>

#include "e2e_support.h"

using namespace reference;
using namespace reference::e2e;

TEST_CASE("detectability limit at 20 dB, k = 20: light-limited, within 3 percent of the independent truth") {
  constexpr double kRose = 20;
  TempDir dir("detectability");
  const CleanCase cc = render_clean_case("20 dB noise", dir.path, issue_case("20 dB noise").scene.snr_db);
  const Truth& truth = cc.truth;
  const double step = level_step(default_layout(), cc.spec.scene), sigma = cc.noise_sigma;
  int covered = 0, samples = 0;
  for (int seed = 1; seed <= 3; ++seed) {
    Image noisy = cc.clean;
    add_gaussian_noise(noisy, sigma, 500 + seed);
    const fs::path image = dir.path / ("capture" + std::to_string(seed) + cc.spec.extension);
    write_image(image.string(), noisy);
    const CaseResult r = measure_and_compare("detectability seed " + std::to_string(seed), image, cc.camera_model, truth,
                                             dir.path / ("capture" + std::to_string(seed) + ".json"),
                                             "--detectability-k 20");
    REQUIRE(r.usable);
    for (const char* orientation : {"horizontal_bars", "vertical_bars"}) {
      CAPTURE(orientation);
      const double f_true = detectability_limit_lp_per_mm(truth, orientation, step, sigma, kRose);
      REQUIRE(f_true > 0);
      // The noise limits: the true detectability limit lies below the optics'.
      CHECK(f_true < truth.limit(orientation).interpolated_lp_per_mm);
      const MeasuredLimit& L = r.limit(orientation);  // the reported limit
      REQUIRE(L.interpolated_lp_per_mm);
      const double rel = *L.interpolated_lp_per_mm / f_true - 1;
      CHECK(std::abs(rel) <= 0.03);
      ++samples;
      covered += L.uncertainty_lp_per_mm && std::abs(*L.interpolated_lp_per_mm - f_true) <= 2 * *L.uncertainty_lp_per_mm;
      MESSAGE(std::string(orientation) << " seed " << seed << ": " << *L.interpolated_lp_per_mm << " vs true " << f_true << " ("
                          << 100 * rel << " %), sigma " << L.uncertainty_lp_per_mm.value_or(0));
    }
  }
  MESSAGE("2-sigma coverage " << covered << " of " << samples);
  CHECK(covered >= samples - 1);
}
