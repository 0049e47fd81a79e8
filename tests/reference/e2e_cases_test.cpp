// End to end on the independent reference renderer's captures (issue 12):
// each capture is measured by the real `tactres measure` with DEFAULT options
// (image, --layout, --camera, -o) and compared with the renderer's own truth.
//
// Acceptance figures asserted (issue 12, "Done when"):
// - every capture is measured: exit 0 or 1, usable, both interpolated limits;
// - noise-free: each |relative error| of the interpolated limit <= 1.5 %, and
//   the median over the noise-free cases and orientations <= 0.5 %;
// - 40 dB: |relative error| <= 1.5 %;
// - noise-free: |m - m_true| <= 0.015 for every `ok` element whose truth has
//   >= 3 px per bar;
// - no element resolved whose m_true < 0.10 (every case, noisy ones included);
// - 20 dB: measured and nothing falsely resolved (the issue sets no accuracy
//   bound at 20 dB; the summary line shows the error).
//
// For a manual check of the renderer itself, TACTRES_REFERENCE_MEASURE_ARGS
// adds options to every measure call, e.g. "--transfer linear".
#include <algorithm>

#include <doctest/doctest.h>

#include "e2e_support.h"

using namespace reference;
using namespace reference::e2e;

namespace {

void check_measured(const CaseResult& r) {
  INFO(summary_line(r));
  CHECK_MESSAGE((r.exit_code == 0 || r.exit_code == 1), "the capture was refused or failed");
  CHECK(r.usable);
  CHECK(r.horizontal.interpolated_lp_per_mm.has_value());
  CHECK(r.vertical.interpolated_lp_per_mm.has_value());
}

void check_no_false_resolution(const CaseResult& r) {
  std::string list;
  for (const std::string& s : r.falsely_resolved) list += s + "; ";
  INFO(summary_line(r));
  INFO("resolved although m_true < 0.10: " << list);
  CHECK(r.falsely_resolved.empty());
}

void check_limits_within(const CaseResult& r, double max_rel_error) {
  INFO(summary_line(r));
  for (const auto* orientation : {"horizontal_bars", "vertical_bars"}) {
    CAPTURE(orientation);
    const auto rel = r.rel_error(orientation);
    REQUIRE_MESSAGE(rel.has_value(), "no interpolated limit");
    CHECK(std::abs(*rel) <= max_rel_error);
  }
}

void check_m(const CaseResult& r) {
  std::string notes;
  for (const std::string& s : r.notes) notes += s + "; ";
  INFO(summary_line(r));
  INFO("elements at >= 3 px/bar not ok: " << notes);
  CHECK(r.elements_compared >= 12);
  CHECK(r.max_abs_dm <= 0.015);
}

void check_case(const std::string& name) {
  const CaseResult& r = cached_case_result(name);
  MESSAGE(summary_line(r));
  check_measured(r);
  check_no_false_resolution(r);
  const CaseSpec& spec = issue_case(name);
  if (spec.noise_free()) {
    check_limits_within(r, 0.015);
    check_m(r);
  } else if (spec.scene.snr_db >= 40) {
    check_limits_within(r, 0.015);
  }
}

}  // namespace

TEST_SUITE("e2e") {
  TEST_CASE("fronto-parallel") { check_case("fronto-parallel"); }
  TEST_CASE("rotated 30 deg") { check_case("rotated 30 deg"); }
  TEST_CASE("tilted 25 deg") { check_case("tilted 25 deg"); }
  TEST_CASE("mirrored") { check_case("mirrored"); }
  TEST_CASE("wide-angle off-centre") { check_case("wide-angle off-centre"); }
  TEST_CASE("40 dB noise") { check_case("40 dB noise"); }
  TEST_CASE("20 dB noise") { check_case("20 dB noise"); }
  TEST_CASE("32-bit float TIFF") { check_case("32-bit float TIFF"); }
  TEST_CASE("light bars on dark") { check_case("light bars on dark"); }
  TEST_CASE("relief direct") { check_case("relief direct"); }
  TEST_CASE("relief mirrored") { check_case("relief mirrored"); }
  TEST_CASE("2448x2048 roll 23 deg tilt 10 deg") { check_case("2448x2048 roll 23 deg tilt 10 deg"); }

  // Run alone under ctest this renders and measures every noise-free case
  // again (about half a minute); run with the others in one process, it
  // reuses their results.
  TEST_CASE("median |error| of the interpolated limit over the noise-free cases <= 0.5 %") {
    std::vector<double> errors;
    for (const CaseSpec& spec : issue_cases()) {
      if (!spec.noise_free()) continue;
      const CaseResult& r = cached_case_result(spec.name);
      MESSAGE(summary_line(r));
      for (const auto* orientation : {"horizontal_bars", "vertical_bars"})
        // A missing limit counts as a large error, not as a skipped sample.
        errors.push_back(r.rel_error(orientation) ? std::abs(*r.rel_error(orientation)) : 1.0);
    }
    std::sort(errors.begin(), errors.end());
    const size_t n = errors.size();
    const double median = n % 2 ? errors[n / 2] : 0.5 * (errors[n / 2 - 1] + errors[n / 2]);
    MESSAGE("median |relative error| " << 100 * median << " % over " << n << " limits");
    CHECK(median <= 0.005);
  }
}

TEST_CASE("relief lit exactly along x: the vertical bars are measured, the horizontal ones say why they are not") {
  // Light along +x gives no slope across y: the reference patch shows no
  // contrast for horizontal bars. That orientation cannot be scaled (graded
  // low_signal with a note), and must not stop the other from being measured.
  CaseSpec spec = issue_case("relief direct");
  spec.name = "relief lit along x";
  spec.scene.light_azimuth_deg = 0;
  TempDir dir("lit-along-x");
  const CaseResult r = run_case(spec, dir.path);
  INFO(summary_line(r));
  CHECK(r.exit_code == 0);
  CHECK(r.usable);
  CHECK_FALSE(r.horizontal.resolved_any);
  REQUIRE(r.rel_error_v.has_value());
  CHECK(std::abs(*r.rel_error_v) <= 0.015);
  CHECK(r.falsely_resolved.empty());
}

TEST_CASE("relief, noise-free, limit at ~2.8 px per bar: the next element is not called aliased, both limits interpolate") {
  // A noise-free capture's bins have a tiny noise floor, so the model's small
  // error gives a large reduced chi^2 near the sampling limit. Aliasing
  // also needs a misfit comparable to the bars' own fitted signal, measured
  // the same way for a relief's slope signal as for printed bars.
  CaseSpec spec = issue_case("relief direct");
  spec.name = "relief near the sampling limit";
  spec.scene.sigma_mm = 0.0905;
  spec.scene.light_azimuth_deg = -35;
  TempDir dir("relief-near-limit");
  const CaseResult r = run_case(spec, dir.path);
  INFO(summary_line(r));
  CHECK(r.usable);
  for (const auto* orientation : {"horizontal_bars", "vertical_bars"}) {
    CAPTURE(orientation);
    const auto rel = r.rel_error(orientation);
    REQUIRE_MESSAGE(rel.has_value(), "no interpolated limit");
    CHECK(std::abs(*rel) <= 0.015);
  }
  CHECK(r.falsely_resolved.empty());
}
