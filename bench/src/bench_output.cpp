// The bench's text outputs (docs/BENCH.md): bench.csv, one row per capture,
// setting and orientation; bench_summary.csv, one row per setting; the short
// table for stdout; and the writing of the files with the page
// (bench_html.cpp).
#include "tactres/bench/bench.h"

#include <cmath>
#include <functional>
#include <map>
#include <utility>

#include <fmt/format.h>

#include "tactres/bench/bench_html.h"
#include "tactres/util/atomic_file.h"
#include "tactres/util/csv.h"

namespace tactres {
namespace {

namespace fs = std::filesystem;

// Finite numbers only; anything else is an empty cell.
std::string num(double v, int decimals) { return std::isfinite(v) ? fmt::format("{:.{}f}", v, decimals) : ""; }
std::string num(const std::optional<double>& v, int decimals) { return v ? num(*v, decimals) : ""; }
std::string integer(const std::optional<int>& v) { return v ? std::to_string(*v) : ""; }
std::string flag(bool v) { return v ? "1" : "0"; }
std::string flag(const std::optional<bool>& v) { return v ? flag(*v) : ""; }

using Column = std::pair<const char*, std::function<std::string(const BenchRow&)>>;

const std::vector<Column>& columns() {
  static const std::vector<Column> cols = {
      {"scene", [](const BenchRow& r) { return r.scene; }},
      {"target", [](const BenchRow& r) { return r.target; }},
      {"view", [](const BenchRow& r) { return r.view; }},
      {"distance_mm", [](const BenchRow& r) { return num(r.distance_mm, 1); }},
      {"blur_sigma_px", [](const BenchRow& r) { return num(r.blur_sigma_px, 2); }},
      {"snr_db", [](const BenchRow& r) { return num(r.snr_db, 1); }},
      {"roll_deg", [](const BenchRow& r) { return num(r.roll_deg, 1); }},
      {"tilt_deg", [](const BenchRow& r) { return num(r.tilt_deg, 1); }},
      {"offset_x_mm", [](const BenchRow& r) { return num(r.offset_mm[0], 1); }},
      {"offset_y_mm", [](const BenchRow& r) { return num(r.offset_mm[1], 1); }},
      {"supersampling", [](const BenchRow& r) { return std::to_string(r.supersampling); }},
      {"setting", [](const BenchRow& r) { return r.setting; }},
      {"sweep", [](const BenchRow& r) { return r.sweep; }},
      {"preset", [](const BenchRow& r) { return r.preset; }},
      {"bin_px", [](const BenchRow& r) { return num(r.bin_px, 3); }},
      {"fit_psf_shape", [](const BenchRow& r) { return flag(r.fit_psf_shape); }},
      {"pose_boundary_points", [](const BenchRow& r) { return std::to_string(r.pose_boundary_points); }},
      {"orientation", [](const BenchRow& r) { return r.orientation; }},
      {"usable", [](const BenchRow& r) { return flag(r.usable); }},
      {"problem", [](const BenchRow& r) { return r.problem; }},
      {"render_ms", [](const BenchRow& r) { return num(r.render_ms, 3); }},
      {"decode_ms", [](const BenchRow& r) { return num(r.decode_ms, 3); }},
      {"decode_cpu_ms", [](const BenchRow& r) { return num(r.decode_cpu_ms, 3); }},
      {"analysis_ms", [](const BenchRow& r) { return num(r.analysis_ms, 3); }},
      {"analysis_cpu_ms", [](const BenchRow& r) { return num(r.analysis_cpu_ms, 3); }},
      {"locate_fiducials_ms", [](const BenchRow& r) { return num(r.locate_fiducials_ms, 3); }},
      {"pose_ms", [](const BenchRow& r) { return num(r.pose_ms, 3); }},
      {"reference_patch_ms", [](const BenchRow& r) { return num(r.reference_patch_ms, 3); }},
      {"profiles_ms", [](const BenchRow& r) { return num(r.profiles_ms, 3); }},
      {"fits_ms", [](const BenchRow& r) { return num(r.fits_ms, 3); }},
      {"decide_ms", [](const BenchRow& r) { return num(r.decide_ms, 3); }},
      {"other_ms", [](const BenchRow& r) { return num(r.other_ms, 3); }},
      {"truth_group", [](const BenchRow& r) { return integer(r.truth_group); }},
      {"truth_element", [](const BenchRow& r) { return integer(r.truth_element); }},
      {"truth_lp_per_mm", [](const BenchRow& r) { return num(r.truth_lp_per_mm, 4); }},
      {"truth_interpolated_lp_per_mm", [](const BenchRow& r) { return num(r.truth_interpolated_lp_per_mm, 4); }},
      {"truth_px_per_bar", [](const BenchRow& r) { return num(r.truth_px_per_bar, 3); }},
      {"measured_group", [](const BenchRow& r) { return integer(r.measured_group); }},
      {"measured_element", [](const BenchRow& r) { return integer(r.measured_element); }},
      {"measured_lp_per_mm", [](const BenchRow& r) { return num(r.measured_lp_per_mm, 4); }},
      {"measured_interpolated_lp_per_mm",
       [](const BenchRow& r) { return num(r.measured_interpolated_lp_per_mm, 4); }},
      {"uncertainty_lp_per_mm", [](const BenchRow& r) { return num(r.uncertainty_lp_per_mm, 4); }},
      {"relative_error", [](const BenchRow& r) { return num(r.relative_error, 6); }},
      {"discrete_agree", [](const BenchRow& r) { return flag(r.discrete_agree); }},
      {"covered_2sigma", [](const BenchRow& r) { return flag(r.covered_2sigma); }},
  };
  return cols;
}

}  // namespace

std::vector<std::string> bench_csv_columns() {
  std::vector<std::string> names;
  for (const Column& c : columns()) names.emplace_back(c.first);
  return names;
}

std::string bench_csv(const std::vector<BenchRow>& rows) {
  std::string out = fmt::format("{}\n", fmt::join(bench_csv_columns(), ","));
  for (const BenchRow& r : rows) {
    for (size_t i = 0; i < columns().size(); ++i) {
      if (i > 0) out += ',';
      out += csv_cell(columns()[i].second(r));
    }
    out += '\n';
  }
  return out;
}

namespace {

// The summary's columns, as bench.csv's: a cell for each setting's row.
using SummaryColumn = std::pair<const char*, std::function<std::string(const BenchSummary&)>>;

const std::vector<SummaryColumn>& summary_columns() {
  static const std::vector<SummaryColumn> cols = {
      {"setting", [](const BenchSummary& s) { return csv_cell(s.setting); }},
      {"sweep", [](const BenchSummary& s) { return csv_cell(s.sweep); }},
      {"captures", [](const BenchSummary& s) { return std::to_string(s.captures); }},
      {"usable_captures", [](const BenchSummary& s) { return std::to_string(s.usable_captures); }},
      {"orientations", [](const BenchSummary& s) { return std::to_string(s.orientations); }},
      {"errors", [](const BenchSummary& s) { return std::to_string(s.errors); }},
      {"missing_limits", [](const BenchSummary& s) { return std::to_string(s.missing_limits); }},
      {"ms_median", [](const BenchSummary& s) { return num(s.ms_median, 3); }},
      {"ms_mean", [](const BenchSummary& s) { return num(s.ms_mean, 3); }},
      {"wall_ms_median", [](const BenchSummary& s) { return num(s.wall_ms_median, 3); }},
      {"locate_fiducials_ms", [](const BenchSummary& s) { return num(s.locate_fiducials_ms, 3); }},
      {"pose_ms", [](const BenchSummary& s) { return num(s.pose_ms, 3); }},
      {"reference_patch_ms", [](const BenchSummary& s) { return num(s.reference_patch_ms, 3); }},
      {"profiles_ms", [](const BenchSummary& s) { return num(s.profiles_ms, 3); }},
      {"fits_ms", [](const BenchSummary& s) { return num(s.fits_ms, 3); }},
      {"decide_ms", [](const BenchSummary& s) { return num(s.decide_ms, 3); }},
      {"other_ms", [](const BenchSummary& s) { return num(s.other_ms, 3); }},
      {"render_ms_median", [](const BenchSummary& s) { return num(s.render_ms_median, 3); }},
      {"median_abs_error_pct", [](const BenchSummary& s) { return num(s.median_abs_error_pct, 4); }},
      {"p95_abs_error_pct", [](const BenchSummary& s) { return num(s.p95_abs_error_pct, 4); }},
      {"interpolated_rate", [](const BenchSummary& s) { return num(s.interpolated_rate, 4); }},
      {"agreement_rate", [](const BenchSummary& s) { return num(s.agreement_rate, 4); }},
      {"coverage_rate", [](const BenchSummary& s) { return num(s.coverage_rate, 4); }},
      {"pareto", [](const BenchSummary& s) { return flag(s.pareto); }},
  };
  return cols;
}

std::string summary_row(const std::function<std::string(const SummaryColumn&)>& cell) {
  std::string out;
  for (const SummaryColumn& c : summary_columns()) {
    if (!out.empty()) out += ',';
    out += cell(c);
  }
  return out + '\n';
}

}  // namespace

std::string bench_summary_csv(const BenchResult& result) {
  std::string out = summary_row([](const SummaryColumn& c) { return std::string(c.first); });
  for (const BenchSummary& s : result.summaries) out += summary_row([&](const SummaryColumn& c) { return c.second(s); });
  // The decode floor: only its counts and times, in their columns.
  const std::map<std::string, std::string> floor = {
      {"setting", "decode (floor)"},
      {"sweep", "floor"},
      {"captures", std::to_string(result.decodes)},
      {"ms_median", num(result.decode_ms_median, 3)},
      {"ms_mean", num(result.decode_ms_mean, 3)},
      {"wall_ms_median", num(result.decode_wall_ms_median, 3)},
      {"pareto", "0"}};
  out += summary_row([&](const SummaryColumn& c) {
    const auto it = floor.find(c.first);
    return it == floor.end() ? std::string() : it->second;
  });
  return out;
}

std::string bench_table_text(const BenchResult& r) {
  auto pct = [](const std::optional<double>& v, int w) {
    return v ? fmt::format("{:>{}.2f}", *v, w) : fmt::format("{:>{}}", "-", w);
  };
  auto rate = [](const std::optional<double>& v, int w) {
    return v ? fmt::format("{:>{}.0f}%", 100 * *v, w - 1) : fmt::format("{:>{}}", "-", w);
  };
  std::string out = fmt::format("tactres bench{}: {} scenes, {} measurements; {}\n", r.quick ? " --quick" : "", r.scenes,
                                r.captures, r.machine);
  out += fmt::format("{:<36} {:>9} {:>7} {:>8} {:>8} {:>6} {:>6} {:>6} {:>7} {:>5}\n", "setting", "ms/capt.", "(wall)",
                     "med|e|%", "p95|e|%", "interp", "agree", "cover", "usable", "front");
  for (const BenchSummary& s : r.summaries)
    out += fmt::format("{:<36} {:>9.1f} {:>7.1f} {} {} {} {} {} {:>7} {:>5}\n", s.setting, s.ms_median, s.wall_ms_median,
                       pct(s.median_abs_error_pct, 8), pct(s.p95_abs_error_pct, 8), rate(s.interpolated_rate, 6),
                       rate(s.agreement_rate, 6), rate(s.coverage_rate, 6),
                       fmt::format("{}/{}", s.usable_captures, s.captures), s.pareto ? "*" : "");
  out += fmt::format("{:<36} {:>9.1f} {:>7.1f}   (OpenImageIO load_image, median of {}; p95 {:.1f} ms)\n",
                     "decode (floor)", r.decode_ms_median, r.decode_wall_ms_median, r.decodes, r.decode_ms_p95);
  out += "ms/capt.: median thread CPU time of the analysis (usable captures); (wall): median wall clock\n";
  out += "\nmedian wall-clock ms per stage (usable captures):\n";
  out += fmt::format("{:<36} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8}\n", "setting", "fiducial", "pose", "patch",
                     "profiles", "fits", "decide", "other");
  for (const BenchSummary& s : r.summaries)
    if (s.sweep == "preset")
      out += fmt::format("{:<36} {:>8.1f} {:>8.1f} {:>8.1f} {:>8.1f} {:>8.1f} {:>8.1f} {:>8.1f}\n", s.setting,
                         s.locate_fiducials_ms, s.pose_ms, s.reference_patch_ms, s.profiles_ms, s.fits_ms,
                         s.decide_ms, s.other_ms);
  if (!r.live.empty()) {
    out += "\n";
    out += live_bench_table_text(r.live);
  }
  out += fmt::format("\nrender {:.0f} s (multi-threaded), measure + decode {:.0f} s (single-threaded), wall {:.0f} s\n",
                     r.render_seconds, r.measure_seconds, r.wall_seconds);
  return out;
}

void write_bench_outputs(const BenchResult& result, const fs::path& dir, const HtmlReportOptions& html) {
  // The page first: it is the one output that can fail for want of a file
  // (Chart.js), and then nothing is half written.
  const std::string page = render_bench_html(result, html);
  write_file_atomically(dir / "bench.csv", bench_csv(result.rows));
  write_file_atomically(dir / "bench_summary.csv", bench_summary_csv(result));
  write_file_atomically(dir / "bench.html", page);
  if (!result.live.empty()) write_file_atomically(dir / "live.csv", live_bench_csv(result.live));
}

}  // namespace tactres
