#include "tactres/reports/comparison.h"

#include <doctest/doctest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "test_measurements.h"

namespace tactres {
namespace {

namespace fs = std::filesystem;
using testing::HandLimit;
using testing::HandMeasurement;
using testing::hand_measurement;
using testing::ReportTempDir;

MeasurementRecord record(const HandMeasurement& m, const std::string& file) {
  return measurement_from_json(hand_measurement(m), file);
}

HandMeasurement make(const std::string& design, std::optional<double> h, std::optional<double> v,
                     double sigma = 0.1) {
  HandMeasurement m;
  m.design = design;
  m.h.interp = h;
  m.h.sigma = h ? std::optional<double>(sigma) : std::nullopt;
  m.v.interp = v;
  m.v.sigma = v ? std::optional<double>(sigma) : std::nullopt;
  return m;
}

// Reference: H 8.0, V 10.0 lp/mm (interpolated), mean 9.0.
MeasurementRecord reference() {
  HandMeasurement m = make("cmos", 8.0, 10.0, 0.2);
  m.h.group = m.v.group = 3;
  m.h.lp_per_mm = m.v.lp_per_mm = 8.0;
  return record(m, "cmos.json");
}

const DesignRow& row(const Comparison& c, const std::string& design) {
  for (const DesignRow& r : c.designs)
    if (r.design == design) return r;
  FAIL("no row " << design);
  throw std::logic_error("unreachable");
}

template <typename F>
std::string refusal(F&& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST_CASE("percentages of the reference, mean of H and V, and its percentage") {
  const Comparison c = compare_designs({record(make("A", 6.0, 5.0), "a.json")}, reference());
  const DesignRow& a = row(c, "A");
  CHECK(a.status == RowStatus::ok);
  CHECK(a.n == 1);
  REQUIRE(a.horizontal.pct_of_reference);
  CHECK(*a.horizontal.pct_of_reference == doctest::Approx(75.0));   // 6 / 8
  CHECK(*a.vertical.pct_of_reference == doctest::Approx(50.0));     // 5 / 10
  CHECK(*a.mean_hv_lp_per_mm == doctest::Approx(5.5));
  CHECK(*a.mean_pct_of_reference == doctest::Approx(100.0 * 5.5 / 9.0));
  // One press: the measurement's own uncertainty, no spread.
  CHECK(*a.horizontal.interp_sigma_lp_per_mm == doctest::Approx(0.1));
  CHECK_FALSE(a.horizontal.interp_sd_lp_per_mm);
  CHECK(*a.rank == 1);
  // The reference row: 100 %, its own numbers, never ranked.
  CHECK(c.reference_row.status == RowStatus::reference);
  CHECK(*c.reference_row.horizontal.pct_of_reference == doctest::Approx(100.0));
  CHECK(*c.reference_row.mean_hv_lp_per_mm == doctest::Approx(9.0));
  CHECK_FALSE(c.reference_row.rank);
  CHECK(c.nyquist_h_lp_per_mm == doctest::Approx(10.0));
  CHECK(c.threshold == doctest::Approx(0.10));
}

TEST_CASE("without an interpolated limit the discrete one is compared") {
  HandMeasurement m = make("B", std::nullopt, 5.0);
  m.h.group = 3;
  m.h.element = 4;
  m.h.lp_per_mm = 12.0;
  m.h.beyond_finest = true;  // everything resolved: no crossing to interpolate
  const Comparison c = compare_designs({record(m, "b.json")}, reference());
  const DesignRow& b = row(c, "B");
  CHECK_FALSE(b.horizontal.interp_lp_per_mm);
  CHECK(b.horizontal.beyond_finest);
  CHECK(*b.horizontal.value_lp_per_mm() == doctest::Approx(12.0));
  CHECK(*b.horizontal.pct_of_reference == doctest::Approx(150.0));
  CHECK(*b.mean_hv_lp_per_mm == doctest::Approx(8.5));
}

TEST_CASE("a reference without interpolation: its discrete limit, and a note says so") {
  HandMeasurement ref = make("cmos", std::nullopt, 10.0);
  ref.h.lp_per_mm = 5.0;
  const Comparison c = compare_designs({record(make("A", 6.0, 5.0), "a.json")}, record(ref, "cmos.json"));
  CHECK(*row(c, "A").horizontal.pct_of_reference == doctest::Approx(120.0));  // 6 / 5 discrete
  REQUIRE(c.notes.size() == 1);
  CHECK(c.notes[0].find("discrete") != std::string::npos);
}

TEST_CASE("repeated presses: mean, sample SD, combined uncertainty, coarsest discrete limit") {
  HandMeasurement p1 = make("T1", 5.0, 4.0, 0.1), p2 = make("T1", 6.0, 4.0, 0.2), p3 = make("T1", 7.0, 4.0, 0.3);
  p2.h.element = 3;
  p2.h.lp_per_mm = 5.04;
  p1.h.lp_per_mm = 4.49;
  p1.h.element = 2;
  p3.h.lp_per_mm = 5.66;
  p3.h.element = 4;
  const Comparison c = compare_designs(
      {record(p1, "t1a.json"), record(make("X", 4.0, 4.0), "x.json"), record(p2, "t1b.json"), record(p3, "t1c.json")},
      reference());
  REQUIRE(c.designs.size() == 2);
  CHECK(c.designs[0].design == "T1");  // order of first appearance
  const DesignRow& t = row(c, "T1");
  CHECK(t.n == 3);
  CHECK(t.presses == std::vector<size_t>{0, 2, 3});
  CHECK(*t.horizontal.interp_lp_per_mm == doctest::Approx(6.0));
  CHECK(*t.horizontal.interp_sd_lp_per_mm == doctest::Approx(1.0));  // sample SD of 5, 6, 7
  // sqrt(SD^2 + mean(sigma)^2) = sqrt(1 + 0.2^2)
  CHECK(*t.horizontal.interp_sigma_lp_per_mm == doctest::Approx(std::sqrt(1.04)));
  CHECK(*t.horizontal.pct_of_reference == doctest::Approx(75.0));
  // The discrete limit every press reached: the coarsest, G2E2 4.49.
  CHECK(t.horizontal.element == 2);
  CHECK(t.horizontal.lp_per_mm == doctest::Approx(4.49));
  // Identical values: SD 0, sigma is the mean uncertainty.
  CHECK(*t.vertical.interp_sd_lp_per_mm == doctest::Approx(0.0));
  CHECK(*t.vertical.interp_sigma_lp_per_mm == doctest::Approx(0.2));
}

TEST_CASE("a press without a crossing leaves the group without an interpolated mean") {
  HandMeasurement p2 = make("T1", std::nullopt, 4.0);
  p2.h.lp_per_mm = 12.0;
  p2.h.beyond_finest = true;
  const Comparison c = compare_designs({record(make("T1", 5.0, 4.0), "a.json"), record(p2, "b.json")}, reference());
  const DesignRow& t = row(c, "T1");
  CHECK_FALSE(t.horizontal.interp_lp_per_mm);
  CHECK_FALSE(t.horizontal.beyond_finest);  // only one of the two presses
  CHECK(*t.horizontal.value_lp_per_mm() == doctest::Approx(4.0));  // the coarsest discrete limit
}

TEST_CASE("ranks: designs that differ within 2 combined sigma share a rank") {
  // Means 6.0, 5.9 and 5.5; sigma 0.1 per orientation gives 0.0707 per mean
  // and 0.2 for 2 combined sigma: A and B are tied, C is worse than both.
  const Comparison c = compare_designs({record(make("A", 6.0, 6.0), "a.json"), record(make("B", 5.9, 5.9), "b.json"),
                                        record(make("C", 5.5, 5.5), "c.json")},
                                       reference());
  CHECK(*row(c, "A").rank == 1);
  CHECK(*row(c, "B").rank == 1);
  CHECK(*row(c, "C").rank == 3);
  // With tighter error bars the same means are told apart.
  const Comparison t = compare_designs({record(make("A", 6.0, 6.0, 0.01), "a.json"),
                                        record(make("B", 5.9, 5.9, 0.01), "b.json")},
                                       reference());
  CHECK(*row(t, "A").rank == 1);
  CHECK(*row(t, "B").rank == 2);
}

TEST_CASE("ranks: by mean of H and V, ties share a rank, failed and unresolved designs are unranked") {
  HandMeasurement failed = make("F", std::nullopt, std::nullopt);
  failed.usable = false;
  failed.problem = "no target found: check the focus";
  HandMeasurement none = make("N", std::nullopt, 5.0);
  none.h.resolved = false;  // nothing resolved horizontally: no value, no mean
  const Comparison c = compare_designs({record(make("A", 6.0, 6.0), "a.json"), record(failed, "f.json"),
                                        record(make("B", 7.0, 7.0), "b.json"), record(make("C", 5.0, 7.0), "c.json"),
                                        record(none, "n.json"), record(make("D", 2.0, 3.0), "d.json")},
                                       reference());
  CHECK(*row(c, "B").rank == 1);
  CHECK(*row(c, "A").rank == 2);  // mean 6
  CHECK(*row(c, "C").rank == 2);  // mean 6 too
  CHECK(*row(c, "D").rank == 4);
  CHECK_FALSE(row(c, "N").rank);
  CHECK_FALSE(row(c, "N").mean_hv_lp_per_mm);
  CHECK(*row(c, "N").vertical.pct_of_reference == doctest::Approx(50.0));

  // The failed design is shown as failed with its problem, never dropped.
  const DesignRow& f = row(c, "F");
  CHECK(f.status == RowStatus::failed);
  CHECK(f.n == 0);
  CHECK(f.n_failed == 1);
  CHECK_FALSE(f.rank);
  CHECK_FALSE(f.mean_hv_lp_per_mm);
  REQUIRE(f.problems.size() == 1);
  CHECK(f.problems[0] == "f.json: no target found: check the focus");
  CHECK(c.designs.size() == 6);
}

TEST_CASE("a design with some failed presses aggregates the usable ones and says so") {
  HandMeasurement bad = make("T1", std::nullopt, std::nullopt);
  bad.usable = false;
  bad.problem = "clipped";
  const Comparison c =
      compare_designs({record(make("T1", 6.0, 6.0), "a.json"), record(bad, "b.json")}, reference());
  const DesignRow& t = row(c, "T1");
  CHECK(t.status == RowStatus::partly_failed);
  CHECK(t.n == 1);
  CHECK(t.n_failed == 1);
  CHECK(*t.horizontal.interp_lp_per_mm == doctest::Approx(6.0));
  CHECK(*t.rank == 1);
}

TEST_CASE("refusals: failed reference, mixed layouts, mixed criteria, no designs") {
  CHECK(refusal([] { compare_designs({}, reference()); }).find("no design measurements") != std::string::npos);

  HandMeasurement bad_ref = make("cmos", std::nullopt, std::nullopt);
  bad_ref.usable = false;
  bad_ref.problem = "no target found";
  const std::string failed_ref =
      refusal([&] { compare_designs({record(make("A", 6.0, 5.0), "a.json")}, record(bad_ref, "cmos.json")); });
  CHECK(failed_ref.find("the reference cmos.json is a failed measurement (no target found)") != std::string::npos);

  HandMeasurement other = make("B", 6.0, 5.0);
  other.layout = "other/layout.json";
  const std::string mixed = refusal([&] {
    compare_designs({record(make("A", 6.0, 5.0), "a.json"), record(other, "b.json")}, reference());
  });
  CHECK(mixed.find("mixed layouts: a.json was measured on layout \"target/layout.json\" but b.json on "
                   "\"other/layout.json\"") != std::string::npos);

  const std::string ref_layout =
      refusal([&] { compare_designs({record(other, "b.json")}, reference()); });
  CHECK(ref_layout.find("the reference cmos.json was measured on layout \"target/layout.json\" but the designs on "
                        "\"other/layout.json\"") != std::string::npos);

  // One layout file given by two paths (measured from two working
  // directories): the same when measure recorded the same digest, not when
  // the digests differ.
  HandMeasurement here = make("A", 6.0, 5.0), there = make("B", 6.0, 5.0);
  here.layout = "tgt/layout.json";
  there.layout = "../tgt/layout.json";
  HandMeasurement ref = make("cmos", 7.0, 6.0);
  ref.layout = "/abs/tgt/layout.json";
  here.layout_sha1 = there.layout_sha1 = ref.layout_sha1 = std::string(40, 'a');
  CHECK_NOTHROW(compare_designs({record(here, "a.json"), record(there, "b.json")}, record(ref, "cmos.json")));
  there.layout_sha1 = std::string(40, 'b');
  CHECK(refusal([&] {
          compare_designs({record(here, "a.json"), record(there, "b.json")}, record(ref, "cmos.json"));
        }).find("mixed layouts") != std::string::npos);
  // One path, two digests: the layout was regenerated between the runs.
  there.layout = here.layout;
  CHECK(refusal([&] {
          compare_designs({record(here, "a.json"), record(there, "b.json")}, record(ref, "cmos.json"));
        }).find("mixed layouts") != std::string::npos);

  HandMeasurement changed = make("B", 6.0, 5.0);
  changed.finest_lp_per_mm = 9.0;  // same file name, other element series
  const std::string series = refusal([&] { compare_designs({record(changed, "b.json")}, reference()); });
  CHECK(series.find("list different elements") != std::string::npos);
  CHECK(series.find("b.json") != std::string::npos);

  HandMeasurement strict = make("B", 6.0, 5.0);
  strict.threshold = 0.2;
  const std::string crit = refusal([&] {
    compare_designs({record(make("A", 6.0, 5.0), "a.json"), record(strict, "b.json")}, reference());
  });
  CHECK(crit.find("mixed criteria: a.json used threshold 0.1 (z 2) but b.json threshold 0.2") != std::string::npos);
  const std::string ref_crit = refusal([&] { compare_designs({record(strict, "b.json")}, reference()); });
  CHECK(ref_crit.find("mixed criteria: the reference cmos.json used threshold 0.1") != std::string::npos);
}

TEST_CASE("load_comparison: files, the reference skipped in a glob, and refusals") {
  ReportTempDir dir("reports-compare");
  const fs::path ref = dir.write("cmos.json", hand_measurement(make("cmos", 8.0, 10.0)).dump());
  const fs::path a = dir.write("a.json", hand_measurement(make("A", 6.0, 5.0)).dump());
  const fs::path b = dir.write("b.json", hand_measurement(make("B", 4.0, 5.0)).dump());

  // A glob such as out/*.json includes the reference itself: it is not a design.
  const Comparison c = load_comparison({a, ref, b}, ref);
  REQUIRE(c.designs.size() == 2);
  CHECK(c.measurements[0].path == a);
  CHECK(*row(c, "B").horizontal.pct_of_reference == doctest::Approx(50.0));

  CHECK(refusal([&] { load_comparison({}, ref); }).find("no measurement JSONs given") != std::string::npos);
  CHECK(refusal([&] { load_comparison({a}, ""); }).find("no reference") != std::string::npos);
  CHECK(refusal([&] { load_comparison({ref}, ref); }).find("the only measurement given is the reference") !=
        std::string::npos);
  CHECK(refusal([&] { load_comparison({a, dir.path / "." / "a.json"}, ref); }).find("is given twice") !=
        std::string::npos);

  // A design file that cannot be read is a failed row; the others stand.
  const fs::path broken = dir.write("broken.json", "{\"schema\": ");
  const Comparison with_bad = load_comparison({a, broken, dir.path / "nope.json", b}, ref);
  REQUIRE(with_bad.designs.size() == 4);
  CHECK(row(with_bad, "A").status == RowStatus::ok);
  CHECK(row(with_bad, "B").status == RowStatus::ok);
  CHECK(*row(with_bad, "B").horizontal.pct_of_reference == doctest::Approx(50.0));
  const DesignRow& bad = row(with_bad, "broken");
  CHECK(bad.status == RowStatus::failed);
  REQUIRE(bad.problems.size() == 1);
  CHECK(bad.problems[0].find(broken.string() + " is not valid JSON") == 0);
  CHECK(row(with_bad, "nope").status == RowStatus::failed);
  // An unreadable reference is refused: every percentage needs it.
  const std::string m = refusal([&] { load_comparison({a}, broken); });
  CHECK(m.find(broken.string()) != std::string::npos);
  try {
    load_comparison({a}, dir.path / "nope.json");
    FAIL("no error for a missing reference");
  } catch (const std::runtime_error& e) {
    CHECK(std::string(e.what()).find("nope.json") != std::string::npos);
  }
}

TEST_CASE("one layout spelt two ways is one layout when the files are identical") {
  ReportTempDir dir("reports-layout");
  const fs::path l1 = dir.write("layout.json", "{\"same\": true}");
  fs::create_directories(dir.path / "copy");
  const fs::path l2 = dir.write("copy/layout.json", "{\"same\": true}");
  HandMeasurement ref = make("cmos", 8.0, 10.0), a = make("A", 6.0, 5.0);
  ref.layout = l1.string();
  a.layout = l2.string();
  CHECK_NOTHROW(compare_designs({record(a, "a.json")}, record(ref, "cmos.json")));
  dir.write("copy/layout.json", "{\"same\": false}");
  CHECK(refusal([&] { compare_designs({record(a, "a.json")}, record(ref, "cmos.json")); })
            .find("the reference cmos.json was measured on layout") != std::string::npos);
}

// /2 measurements: reference H 8, V 10 (optics-limited); "A" 6 and 6, limited
// by its optics with light to spare; "L" whose optics would reach 7 and 9
// but whose bars sink into the noise at 4 and 5.
HandMeasurement v2(HandMeasurement m) {
  m.schema = 2;
  return m;
}
HandMeasurement light_limited(const std::string& design) {
  HandMeasurement m = v2(make(design, 4.0, 5.0));
  testing::limit_by_light(m.h, 7.0, 1.8, m.h_parts);
  testing::limit_by_light(m.v, 9.0, 1.2, m.v_parts);
  return m;
}
MeasurementRecord reference_v2() {
  HandMeasurement m = v2(make("cmos", 8.0, 10.0, 0.2));
  m.h.group = m.v.group = 3;
  m.h.lp_per_mm = m.v.lp_per_mm = 8.0;
  return record(m, "cmos.json");
}

TEST_CASE("two limits: optical, detectability and reported as % of raw CMOS, the limiting factor, light needed") {
  const Comparison c =
      compare_designs({record(v2(make("A", 6.0, 6.0)), "a.json"), record(light_limited("L"), "l.json")}, reference_v2());
  CHECK(c.detectability_k == doctest::Approx(5.0));
  const DesignRow& l = row(c, "L");
  CHECK(l.horizontal_parts.limited_by == LimitedBy::light_noise);
  CHECK(l.vertical_parts.limited_by == LimitedBy::light_noise);
  CHECK(l.horizontal_parts.light_limited_presses == 1);
  // All three on the reference's REPORTED limit: 7 / 8, 4 / 8, 4 / 8.
  CHECK(*l.horizontal_parts.optical.pct_of_reference == doctest::Approx(87.5));
  REQUIRE(l.horizontal_parts.detectability);
  CHECK(*l.horizontal_parts.detectability->pct_of_reference == doctest::Approx(50.0));
  CHECK(*l.horizontal.pct_of_reference == doctest::Approx(50.0));
  CHECK(*l.vertical_parts.optical.pct_of_reference == doctest::Approx(90.0));  // 9 / 10
  // Light needed: per orientation as measured, the design's is the larger.
  CHECK(*l.horizontal_parts.light_needed_factor == doctest::Approx(1.8));
  CHECK(*l.vertical_parts.light_needed_factor == doctest::Approx(1.2));
  CHECK(*l.light_needed_factor == doctest::Approx(1.8));

  const DesignRow& a = row(c, "A");
  CHECK(a.horizontal_parts.limited_by == LimitedBy::optics);
  CHECK(*a.horizontal_parts.optical.pct_of_reference == doctest::Approx(75.0));
  // Every element detectable: the finest (8 lp/mm), a lower bound.
  REQUIRE(a.vertical_parts.detectability);
  CHECK(a.vertical_parts.detectability->beyond_finest);
  CHECK(*a.vertical_parts.detectability->pct_of_reference == doctest::Approx(80.0));  // 8 / 10
  CHECK(*a.light_needed_factor == doctest::Approx(0.25));
  CHECK(c.reference_row.horizontal_parts.limited_by == LimitedBy::optics);
  CHECK(*c.reference_row.horizontal_parts.optical.pct_of_reference == doctest::Approx(100.0));
}

TEST_CASE("ranks use the reported limit: a light-limited design ranks by what it resolves, not its optics") {
  // L's optics (mean 8) beat A's (6), but light holds L to a mean of 4.5.
  const Comparison c =
      compare_designs({record(light_limited("L"), "l.json"), record(v2(make("A", 6.0, 6.0)), "a.json")}, reference_v2());
  CHECK(*row(c, "A").rank == 1);
  CHECK(*row(c, "L").rank == 2);
  CHECK(*row(c, "L").mean_hv_lp_per_mm == doctest::Approx(4.5));
  // The 2-combined-sigma tie rule still applies to the reported limits.
  const Comparison tie = compare_designs(
      {record(light_limited("L"), "l.json"), record(v2(make("B", 4.5, 4.6)), "b.json")}, reference_v2());
  CHECK(*row(tie, "L").rank == 1);
  CHECK(*row(tie, "B").rank == 1);
}

TEST_CASE("repeated presses: limiting factors that disagree are mixed, the light needed is the largest") {
  HandMeasurement optics = v2(make("T", 6.0, 6.0));
  optics.h_parts.light_needed = optics.v_parts.light_needed = 0.5;
  const Comparison c =
      compare_designs({record(light_limited("T"), "t1.json"), record(optics, "t2.json")}, reference_v2());
  const DesignRow& t = row(c, "T");
  CHECK(t.horizontal_parts.limited_by == LimitedBy::mixed);
  CHECK(t.horizontal_parts.light_limited_presses == 1);
  CHECK(*t.horizontal_parts.light_needed_factor == doctest::Approx(1.8));
  // A press without a factor leaves the design without one.
  optics.h_parts.light_needed = std::nullopt;
  const Comparison u =
      compare_designs({record(light_limited("T"), "t1.json"), record(optics, "t2.json")}, reference_v2());
  CHECK_FALSE(row(u, "T").horizontal_parts.light_needed_factor);
  CHECK_FALSE(row(u, "T").light_needed_factor);
  CHECK(*row(u, "T").vertical_parts.light_needed_factor == doctest::Approx(1.2));
}

TEST_CASE("measurement/1 files still compare: the reported limit is the optical one, detectability unknown") {
  const Comparison c = compare_designs({record(make("A", 6.0, 5.0), "a.json")}, reference());
  const DesignRow& a = row(c, "A");
  CHECK(a.horizontal_parts.limited_by == LimitedBy::unknown);
  CHECK_FALSE(a.horizontal_parts.detectability);
  CHECK(*a.horizontal_parts.optical.pct_of_reference == doctest::Approx(75.0));
  CHECK(*a.horizontal_parts.optical.interp_lp_per_mm == doctest::Approx(6.0));
  CHECK_FALSE(a.light_needed_factor);
  CHECK(*a.rank == 1);
  CHECK(c.detectability_k == 0.0);
  // /1 and /2 presses of one design: the detectability is not known for all.
  const Comparison mixed = compare_designs(
      {record(make("T", 6.0, 5.0), "t1.json"), record(light_limited("T"), "t2.json")}, reference());
  CHECK(row(mixed, "T").horizontal_parts.limited_by == LimitedBy::unknown);
  CHECK_FALSE(row(mixed, "T").horizontal_parts.detectability);
  CHECK(mixed.detectability_k == doctest::Approx(5.0));  // from the /2 input
}

TEST_CASE("refusals: detectability limits from different Rose thresholds") {
  HandMeasurement strict = v2(make("B", 6.0, 5.0));
  strict.detectability_k = 40.0;
  const std::string m =
      refusal([&] { compare_designs({record(v2(make("A", 6.0, 5.0)), "a.json"), record(strict, "b.json")}, reference_v2()); });
  CHECK(m.find("mixed criteria: cmos.json used detectability k 5 but b.json k 40") != std::string::npos);
  // A /1 file has no k to disagree with.
  CHECK_NOTHROW(compare_designs({record(strict, "b.json"), record(make("C", 6.0, 5.0), "c.json")}, reference()));
}

TEST_CASE("light needed as text") {
  CHECK(light_needed_text(1.83) == "×1.8 more light");
  CHECK(light_needed_text(12.4) == "×12 more light");
  CHECK(light_needed_text(0.4) == "0.4×: light to spare");
  CHECK(light_needed_text(0.043) == "0.043×: light to spare");
  CHECK(light_needed_text(0.0004) == "<0.01×: light to spare");
  CHECK(light_needed_text(std::nullopt) == "n/a");
  CHECK(light_needed_text(0.0) == "n/a");
}

}  // namespace
}  // namespace tactres
