// 2-sigma coverage of the interpolated limit on the reference renderer's
// captures (issue 12: "between 90 % and 98 %, for albedo and for relief").
//
// One noise-free render per signature, then seeded repeats at 30 dB (noise
// sigma = level step / 31.6), each measured by `tactres measure` with default
// options. A sample is one orientation of one repeat; it is covered when its
// interpolated limit lies within 2 x uncertainty_lp_per_mm of the truth. A
// missing limit or uncertainty counts as not covered.
//
// The default is 25 seeds (50 samples per signature, about 25 s each);
// TACTRES_REFERENCE_COVERAGE_SEEDS overrides it. With 50 samples the 90-98 %
// window itself has sampling noise (a calibrated 95.4 % interval lands
// outside it about one time in six), so the seeds are fixed.
#include <cmath>
#include <cstdlib>
#include <fstream>

#include <doctest/doctest.h>

#include "e2e_support.h"

using namespace reference;
using namespace reference::e2e;

namespace {

int seed_count() {
  const char* s = std::getenv("TACTRES_REFERENCE_COVERAGE_SEEDS");
  return s && *s ? std::max(1, std::atoi(s)) : 25;
}

struct Coverage {
  int samples = 0, covered = 0;
  double worst_abs_z = 0;
  double sum_z = 0, sum_z2 = 0;
  int with_z = 0;
  double mean_z() const { return with_z ? sum_z / with_z : 0; }
  double rms_z() const { return with_z ? std::sqrt(sum_z2 / with_z) : 0; }
  double percent() const { return samples ? 100.0 * covered / samples : 0; }
};

double snr_db_setting() {
  const char* s = std::getenv("TACTRES_REFERENCE_COVERAGE_SNR_DB");
  return s && *s ? std::atof(s) : 30.0;
}

Coverage coverage_of(const std::string& case_name, double snr_db) {
  TempDir dir("coverage");
  const CleanCase cc = render_clean_case(case_name, dir.path, snr_db);
  const CaseSpec& spec = cc.spec;
  const Truth& truth = cc.truth;
  const Image& clean = cc.clean;
  const fs::path& camera_model = cc.camera_model;
  const double sigma = cc.noise_sigma;

  Coverage c;
  for (int seed = 1; seed <= seed_count(); ++seed) {
    Image noisy = clean;
    add_gaussian_noise(noisy, sigma, 1000 + seed);
    const fs::path image = dir.path / ("capture" + std::to_string(seed) + spec.extension);
    write_image(image.string(), noisy);
    const CaseResult r = measure_and_compare(case_name + " seed " + std::to_string(seed), image, camera_model, truth,
                                             dir.path / ("capture" + std::to_string(seed) + ".json"), "");
    for (const auto* orientation : {"horizontal_bars", "vertical_bars"}) {
      const MeasuredLimit& L = r.limit(orientation);
      ++c.samples;
      if (!L.interpolated_lp_per_mm || !L.uncertainty_lp_per_mm || *L.uncertainty_lp_per_mm <= 0) {
        MESSAGE(summary_line(r) << ": no limit or uncertainty for " << orientation);
        continue;
      }
      const double z = (*L.interpolated_lp_per_mm - truth.limit(orientation).interpolated_lp_per_mm) /
                       *L.uncertainty_lp_per_mm;
      c.worst_abs_z = std::max(c.worst_abs_z, std::abs(z));
      c.sum_z += z;
      c.sum_z2 += z * z;
      ++c.with_z;
      if (std::abs(z) <= 2) ++c.covered;
    }
  }
  return c;
}

void check_coverage(const std::string& case_name) {
  const double snr_db = snr_db_setting();
  const Coverage c = coverage_of(case_name, snr_db);
  MESSAGE(case_name << " at " << snr_db << " dB: 2-sigma coverage " << c.percent() << " % (" << c.covered << " of "
                    << c.samples << "), z = (measured - true) / uncertainty: mean " << c.mean_z() << ", rms "
                    << c.rms_z() << ", worst |z| " << c.worst_abs_z);
  CHECK(c.percent() >= 90);
  CHECK(c.percent() <= 98);
}

}  // namespace

TEST_CASE("2-sigma coverage of the interpolated limit, albedo, 30 dB: 90-98 %") {
  check_coverage("fronto-parallel");
}

TEST_CASE("2-sigma coverage of the interpolated limit, relief, 30 dB: 90-98 %") {
  check_coverage("relief direct");
}
