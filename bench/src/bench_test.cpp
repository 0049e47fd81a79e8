#include "tactres/bench/bench.h"

#include <cmath>
#include <filesystem>
#include <map>
#include <numbers>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <doctest/doctest.h>

#include "scene_fixtures.h"
#include "tactres/util/atomic_file.h"

using namespace tactres;

namespace {

namespace fs = std::filesystem;

// RFC 4180 fields of one CSV line (quoted fields may hold commas and "").
std::vector<std::string> csv_fields(const std::string& line) {
  std::vector<std::string> out(1);
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        out.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        out.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      out.emplace_back();
    } else {
      out.back() += c;
    }
  }
  return out;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  return lines;
}

// The columns docs/BENCH.md documents for bench.csv: the first cell,
// `name`, of each table row in the section "## bench.csv".
std::vector<std::string> documented_columns() {
  const std::string doc = read_file(testing::source_dir() / "docs/BENCH.md");
  std::vector<std::string> cols;
  bool in_section = false;
  const std::regex row(R"(^\| `([a-z0-9_]+)` \|)");
  for (const std::string& l : lines_of(doc)) {
    if (l.rfind("## ", 0) == 0) in_section = l.rfind("## bench.csv", 0) == 0;
    std::smatch m;
    if (in_section && std::regex_search(l, m, row)) cols.push_back(m[1]);
  }
  return cols;
}

// Columns that hold text or flags; every other column is a number.
const std::set<std::string> kTextColumns = {"scene", "target", "view", "setting", "sweep",
                                            "preset", "orientation", "problem"};

}  // namespace

TEST_CASE("bench: the built-in camera is the example wide-angle camera") {
  const CameraModel shipped = testing::wide_angle_camera();
  const CameraModel builtin = bench_default_camera();
  CHECK(builtin.lensmodel_name() == shipped.lensmodel_name());
  CHECK(builtin.imager_width() == shipped.imager_width());
  CHECK(builtin.imager_height() == shipped.imager_height());
  const std::vector<double> a = builtin.intrinsics(), b = shipped.intrinsics();
  REQUIRE(a.size() == b.size());
  for (size_t i = 0; i < a.size(); ++i) CHECK(a[i] == doctest::Approx(b[i]).epsilon(1e-12));
}

TEST_CASE("bench: the suite is fixed and spans every axis the bench promises") {
  const std::vector<BenchScene> suite = bench_suite();
  const std::vector<BenchScene> again = bench_suite();
  REQUIRE(suite.size() == again.size());
  std::set<std::string> names, targets, views;
  std::set<double> snr, sigma, distance;
  int quick = 0, sweep = 0;
  double max_tilt = 0, max_roll = 0;
  for (size_t i = 0; i < suite.size(); ++i) {
    const BenchScene& s = suite[i];
    CHECK(s.name == again[i].name);
    CHECK(s.roll_deg == again[i].roll_deg);  // seeded: the same scenes every run
    CHECK(s.scene.effects.size() == again[i].scene.effects.size());
    names.insert(s.name);
    targets.insert(s.target);
    views.insert(s.view);
    snr.insert(s.snr_db.value_or(-1));
    sigma.insert(s.blur_sigma_px);
    distance.insert(s.distance_mm);
    quick += s.in_quick;
    sweep += s.supersampling_sweep;
    max_tilt = std::max(max_tilt, s.tilt_deg);
    max_roll = std::max(max_roll, std::abs(s.roll_deg));
    CHECK((s.scene.find<SensorOptions>() != nullptr) == s.snr_db.has_value());
    if (const SensorOptions* o = s.scene.find<SensorOptions>()) {
      const double white = s.target == "albedo" ? s.scene.ground_reflectance : 0.9 * std::sin(55 * std::numbers::pi / 180);
      CHECK(snr_db(*o, white) == doctest::Approx(*s.snr_db).epsilon(0.01));
    }
  }
  CHECK(names.size() == suite.size());  // unique: they name the capture files
  CHECK(targets == std::set<std::string>{"albedo", "relief"});
  CHECK(views == std::set<std::string>{"direct", "through_gel"});
  CHECK(snr.count(-1) == 1);
  CHECK(*std::prev(snr.end()) >= 40);
  CHECK(*std::next(snr.begin()) <= 20);
  CHECK(sigma.size() >= 3);
  CHECK(distance.size() >= 3);
  CHECK(quick >= 8);
  CHECK(quick <= 16);
  CHECK(sweep >= 2);
  CHECK(max_tilt >= 10);
  CHECK(max_roll >= 90);

  // The truth limits span group 1 to group 4 (noise-free albedo, direct).
  std::set<int> groups;
  for (const BenchScene& s : suite) {
    if (s.target != "albedo" || s.view != "direct" || s.snr_db) continue;
    const Truth t = compute_truth(s.scene, testing::default_layout(), bench_default_camera());
    for (const Limit* l : {&t.horizontal, &t.vertical})
      if (l->any_resolved) groups.insert(l->group);
  }
  CHECK(groups.count(1) == 1);
  CHECK(groups.count(4) == 1);
}

TEST_CASE("bench: settings are the three presets and the documented sweeps") {
  const std::vector<BenchSetting> settings = bench_settings();
  REQUIRE(settings.size() >= 3);
  CHECK(settings[0].name == "fast");
  CHECK(settings[1].name == "balanced");
  CHECK(settings[2].name == "precise");
  std::set<std::string> sweeps;
  for (const BenchSetting& s : settings) {
    sweeps.insert(s.sweep);
    CHECK_NOTHROW(s.options.validate());
    CHECK((s.sweep == "supersampling") == (s.supersampling > 0));
  }
  CHECK(sweeps == std::set<std::string>{"preset", "bin_px", "fit_psf_shape", "pose_boundary_points", "supersampling"});

  BenchOptions o;
  o.out_dir = "unused";
  o.scenes = {"no-such-scene"};
  CHECK_THROWS_AS(o.validate(), std::invalid_argument);
  o.scenes = {};
  o.settings = {"turbo"};
  CHECK_THROWS_AS(o.validate(), std::invalid_argument);
  o.settings = {};
  o.out_dir.clear();
  CHECK_THROWS_AS(o.validate(), std::invalid_argument);
}

TEST_CASE("bench: summaries, percentiles and the Pareto front") {
  // Three settings; errors in % of a true limit of 5 lp/mm, uncertainty 0.06.
  auto row = [](const std::string& setting, const std::string& orientation, double ms,
                std::optional<double> err_pct) {
    BenchRow r;
    r.setting = setting;
    r.sweep = "preset";
    r.orientation = orientation;
    r.usable = true;
    r.analysis_cpu_ms = ms;
    r.analysis_ms = ms + 5;  // wall: a shared machine adds waits
    r.truth_interpolated_lp_per_mm = 5.0;
    r.discrete_agree = err_pct && std::abs(*err_pct) < 3;
    if (err_pct) {
      r.measured_interpolated_lp_per_mm = 5.0 * (1 + *err_pct / 100);
      r.relative_error = *err_pct / 100;
      r.uncertainty_lp_per_mm = 0.06;  // 2 sigma = 0.12 lp/mm: 2 % covered, 4 % not
      r.covered_2sigma = std::abs(*r.measured_interpolated_lp_per_mm - 5.0) <= 0.1;
    }
    return r;
  };
  const std::string H = "horizontal_bars", V = "vertical_bars";
  std::vector<BenchRow> rows = {
      row("slow", H, 100, 1),   row("slow", V, 100, -1),  row("slow", H, 120, 2),
      row("slow", V, 120, 4),   row("slow", H, 110, 1),   row("slow", V, 110, std::nullopt),
      row("quick", H, 10, 5),   row("quick", V, 10, -5),  row("quick", H, 30, 5),
      row("quick", V, 30, 5),   row("worse", H, 200, 6),  row("worse", V, 200, 6),
      row("worse", H, 1, std::nullopt), row("worse", V, 1, std::nullopt),  // made unusable below
  };
  rows[12].usable = rows[13].usable = false;
  const std::vector<BenchSummary> s = summarize_bench(rows);
  REQUIRE(s.size() == 3);
  CHECK(s[0].setting == "slow");
  CHECK(s[0].captures == 3);
  CHECK(s[0].ms_median == doctest::Approx(110));
  CHECK(s[0].ms_mean == doctest::Approx(110));
  CHECK(s[0].wall_ms_median == doctest::Approx(115));
  CHECK(s[0].errors == 5);  // |e| = 1, 1, 2, 4, 1
  CHECK(s[0].missing_limits == 1);
  CHECK(*s[0].median_abs_error_pct == doctest::Approx(1));
  CHECK(*s[0].p95_abs_error_pct == doctest::Approx(2 + 0.8 * (4 - 2)));  // type 7: between 2 and 4
  CHECK(*s[0].interpolated_rate == doctest::Approx(5.0 / 6));
  CHECK(*s[0].coverage_rate == doctest::Approx(4.0 / 5));  // 4 % of 5 = 0.2 > 0.12
  CHECK(s[1].setting == "quick");
  CHECK(s[1].ms_median == doctest::Approx(20));
  CHECK(*s[1].median_abs_error_pct == doctest::Approx(5));
  CHECK(*s[1].agreement_rate == doctest::Approx(0));
  CHECK(*s[1].coverage_rate == doctest::Approx(0));
  CHECK(s[0].pareto);        // most accurate
  CHECK(s[1].pareto);        // fastest
  CHECK_FALSE(s[2].pareto);  // slower and less accurate than both
  // An unusable capture counts as a capture, not in the time nor as a
  // missing limit (the usable column says it).
  CHECK(s[2].captures == 2);
  CHECK(s[2].usable_captures == 1);
  CHECK(s[2].ms_median == doctest::Approx(200));
  CHECK(s[2].missing_limits == 0);
  CHECK(s[2].orientations == 2);
}

TEST_CASE("bench: a tiny bench writes the documented CSV columns with finite numbers") {
  const std::vector<std::string> documented = documented_columns();
  REQUIRE(documented.size() >= 30);
  CHECK(bench_csv_columns() == documented);

  testing::TempDir dir("bench");
  BenchOptions o;
  o.out_dir = dir.path;
  o.scenes = {"albedo-direct-d34-b2.5-clean", "albedo-direct-d26-b1.6-snr20"};
  o.settings = {"fast"};
  std::vector<std::string> progress;
  const BenchResult r = run_bench(o, [&](const std::string& line) { progress.push_back(line); });
  CHECK(progress.size() == 2);
  CHECK(r.scenes == 2);
  CHECK(r.captures == 2);
  REQUIRE(r.rows.size() == 4);  // 2 captures x 1 setting x 2 orientations
  CHECK(fs::exists(dir.path / "captures/albedo-direct-d34-b2.5-clean.tif"));
  CHECK(fs::exists(dir.path / "captures/albedo-direct-d26-b1.6-snr20.png"));
  CHECK(fs::exists(dir.path / "captures/albedo-direct-d34-b2.5-clean.truth.json"));
  CHECK(fs::exists(dir.path / "layout.json"));
  CHECK(fs::exists(dir.path / "camera.cameramodel"));
  CHECK(r.decodes == 2);
  CHECK(r.decode_ms_median > 0);

  write_bench_outputs(r, dir.path);
  const std::vector<std::string> lines = lines_of(read_file(dir.path / "bench.csv"));
  REQUIRE(lines.size() == 5);
  const std::vector<std::string> header = csv_fields(lines[0]);
  CHECK(header == documented);
  int usable = 0, with_error = 0;
  for (size_t i = 1; i < lines.size(); ++i) {
    const std::vector<std::string> f = csv_fields(lines[i]);
    REQUIRE(f.size() == header.size());
    std::map<std::string, std::string> cell;
    for (size_t k = 0; k < f.size(); ++k) cell[header[k]] = f[k];
    CAPTURE(lines[i]);
    CHECK(cell["setting"] == "fast");
    CHECK(cell["preset"] == "fast");
    for (const auto& [name, value] : cell) {
      if (kTextColumns.count(name) || value.empty()) continue;
      CAPTURE(name);
      size_t used = 0;
      const double v = std::stod(value, &used);
      CHECK(used == value.size());
      CHECK(std::isfinite(v));
    }
    if (cell["usable"] == "1") {
      ++usable;
      for (const char* t : {"decode_ms", "decode_cpu_ms", "analysis_ms", "analysis_cpu_ms", "locate_fiducials_ms",
                            "pose_ms", "fits_ms"}) {
        REQUIRE_FALSE(cell[t].empty());
        CHECK(std::stod(cell[t]) >= 0);
      }
      CHECK(std::stod(cell["analysis_ms"]) > 0);
      CHECK(std::stod(cell["analysis_cpu_ms"]) > 0);
      CHECK_FALSE(cell["discrete_agree"].empty());
    }
    if (!cell["relative_error"].empty()) ++with_error;
    CHECK_FALSE(cell["truth_interpolated_lp_per_mm"].empty());  // both scenes have a true crossing
  }
  CHECK(usable >= 2);
  CHECK(with_error >= 1);

  const std::string table = bench_table_text(r);
  CHECK(table.find("fast") != std::string::npos);
  CHECK(table.find("decode (floor)") != std::string::npos);
  const std::vector<std::string> summary = lines_of(read_file(dir.path / "bench_summary.csv"));
  REQUIRE(summary.size() == 3);  // header, fast, decode floor
  CHECK(csv_fields(summary[1])[0] == "fast");
  CHECK(csv_fields(summary[2])[0] == "decode (floor)");
  // Every row has the header's columns (the floor row was one short).
  const std::vector<std::string> summary_header = csv_fields(summary[0]);
  for (const std::string& line : summary) CHECK(csv_fields(line).size() == summary_header.size());
  CHECK(csv_fields(summary[2]).back() == "0");  // the floor is no Pareto setting, in the pareto column
  const std::string html = read_file(dir.path / "bench.html");
  CHECK(html.find("<canvas") != std::string::npos);
  CHECK(html.find("data-charts-expected=\"3\"") != std::string::npos);
  CHECK(html.find("Chart.js v") != std::string::npos);  // inlined
  CHECK(html.find("<script src") == std::string::npos);  // self-contained: nothing to fetch
  CHECK(html.find("<link") == std::string::npos);
}

TEST_CASE("bench: the live figures measure every frame, track after the first, and write a finite live.csv") {
  testing::TempDir dir("bench-live");
  LiveBenchOptions o;
  o.frames = 4;
  o.chart = false;
  o.only = "fast, tracked";  // both tracked fast settings
  o.out_dir = dir.path;
  std::vector<std::string> progress;
  const std::vector<LiveBenchRow> rows = run_live_bench(o, [&](const std::string& line) { progress.push_back(line); });
  REQUIRE(rows.size() == 2);
  CHECK(progress.size() == 2);
  for (const LiveBenchRow& r : rows) {
    CAPTURE(r.setting);
    CHECK(r.mode == "layout 1280x720");
    CHECK(r.frames == 4);
    CHECK(r.measured == 4);
    CHECK(r.tracked == 3);  // the first frame is searched from scratch
    CHECK(r.cpu_ms_median > 0);
    REQUIRE(r.goal_ms);
    CHECK(*r.goal_ms == 5);
    CHECK(r.goal_met() == (r.cpu_ms_median <= 5));
    std::set<std::string> stages;
    for (const auto& [stage, ms] : r.stage_ms) stages.insert(stage);
    CHECK(stages.count("fits"));
    CHECK(stages.count("locate_fiducials"));
  }
  CHECK(rows[0].setting == "fast, tracked");
  CHECK(rows[1].setting == "fast, tracked, near-limit");
  CHECK(fs::exists(dir.path / "live" / "layout-003.png"));

  const std::vector<std::string> lines = lines_of(live_bench_csv(rows));
  REQUIRE(lines.size() == 3);
  CHECK(lines[0] == "mode,setting,frames,measured,tracked,cpu_ms_median,wall_ms_median,goal_ms,goal_met,stages");
  for (size_t i = 1; i < lines.size(); ++i) {
    const std::vector<std::string> f = csv_fields(lines[i]);
    REQUIRE(f.size() == 10);
    CHECK(f[1] == rows[i - 1].setting);  // the comma in the name is quoted
    CHECK(std::isfinite(std::stod(f[5])));
    CHECK(f[8] == (rows[i - 1].goal_met() ? "true" : "false"));
  }
  const std::string table = live_bench_table_text(rows);
  CHECK(table.find("fast, tracked, near-limit") != std::string::npos);
  CHECK(table.find("nan") == std::string::npos);

  BenchResult result;
  result.live = rows;
  write_bench_outputs(result, dir.path);
  CHECK(read_file(dir.path / "live.csv") == live_bench_csv(rows));
  const std::string html = read_file(dir.path / "bench.html");
  CHECK(html.find("Live mode (tactres watch)") != std::string::npos);
  CHECK(html.find("fast, tracked, near-limit") != std::string::npos);

  LiveBenchOptions bad = o;
  bad.frames = 2;
  CHECK_THROWS_AS(bad.validate(), std::invalid_argument);
}
