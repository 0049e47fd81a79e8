#include "tactres/bench/bench_html.h"

#include "bench_assets.h"  // generated from the assets folder at build time

#include <cctype>
#include <cmath>
#include <map>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>


namespace tactres {
namespace {

using nlohmann::json;

// The bench's own style, after the shared one (html_page.cpp).
constexpr const char* kBenchCss = kAsset_bench_css;  // bench/assets/bench.css

// The three charts, inside the shared page script (html_page.h: `data`,
// `body`, the rendered-charts counter and textLabels are set up there).
constexpr const char* kBenchChartScript = kAsset_bench_charts_js;  // bench/assets/bench_charts.js

json opt(const std::optional<double>& v) { return v && std::isfinite(*v) ? json(*v) : json(); }

// Short labels for the chart: the part after "balanced ".
std::string short_label(const BenchSummary& s) {
  const std::string prefix = "balanced ";
  return s.sweep != "preset" && s.setting.rfind(prefix, 0) == 0 ? s.setting.substr(prefix.size()) : s.setting;
}

json page_data(const BenchResult& r) {
  json settings = json::array();
  for (const BenchSummary& s : r.summaries)
    settings.push_back({{"setting", s.setting},
                        {"label", short_label(s)},
                        {"sweep", s.sweep},
                        {"captures", s.captures},
                        {"usable_captures", s.usable_captures},
                        {"ms_median", s.ms_median},
                        {"ms_mean", s.ms_mean},
                        {"wall_ms_median", s.wall_ms_median},
                        {"render_ms_median", s.render_ms_median},
                        {"median_error_pct", opt(s.median_abs_error_pct)},
                        {"p95_error_pct", opt(s.p95_abs_error_pct)},
                        {"interpolated_rate", opt(s.interpolated_rate)},
                        {"agreement_rate", opt(s.agreement_rate)},
                        {"coverage_rate", opt(s.coverage_rate)},
                        {"pareto", s.pareto},
                        {"stages",
                         {{"locate_fiducials_ms", s.locate_fiducials_ms},
                          {"pose_ms", s.pose_ms},
                          {"reference_patch_ms", s.reference_patch_ms},
                          {"profiles_ms", s.profiles_ms},
                          {"fits_ms", s.fits_ms},
                          {"decide_ms", s.decide_ms},
                          {"other_ms", s.other_ms}}}});
  return {{"settings", settings},
          {"decode_ms_median", r.decode_ms_median},
          {"decode_ms_p95", r.decode_ms_p95},
          {"decode_wall_ms_median", r.decode_wall_ms_median}};
}

std::string cell(const std::optional<double>& v, double scale, int digits, const char* unit = "") {
  return v ? fmt::format("{:.{}f}{}", *v * scale, digits, unit) : "&ndash;";
}

std::string summary_table(const BenchResult& r) {
  std::string s =
      "<table>\n<thead><tr><th class=\"name\">setting</th><th>captures usable</th><th>CPU ms / capture<br>"
      "median</th><th>CPU ms / capture<br>mean</th><th>wall ms / capture<br>median</th><th>median<br>|error|</th><th>p95<br>|error|</th><th>interpolated<br>limit "
      "reported</th><th>discrete<br>agreement</th><th>2&sigma;<br>coverage</th><th>render ms<br>median</th>"
      "</tr></thead>\n<tbody>\n";
  for (const BenchSummary& b : r.summaries)
    s += fmt::format(
        "<tr{}><td class=\"name\">{}</td><td>{}/{}</td><td>{:.1f}</td><td>{:.1f}</td><td>{:.1f}</td><td>{}</td>"
        "<td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.0f}</td></tr>\n",
        b.pareto ? " class=\"front\"" : "", html_escape(b.setting), b.usable_captures, b.captures, b.ms_median,
        b.ms_mean, b.wall_ms_median, cell(b.median_abs_error_pct, 1, 2, " %"), cell(b.p95_abs_error_pct, 1, 2, " %"),
        cell(b.interpolated_rate, 100, 0, " %"), cell(b.agreement_rate, 100, 0, " %"),
        cell(b.coverage_rate, 100, 0, " %"), b.render_ms_median);
  s += fmt::format(
      "<tr class=\"floor\"><td class=\"name\">decode floor (load_image)</td><td>{} loads</td><td>{:.1f}</td>"
      "<td>{:.1f}</td><td>{:.1f}</td><td colspan=\"6\" class=\"text\">CPU p95 {:.1f} ms: no analysis of these "
      "files can be faster</td></tr>\n",
      r.decodes, r.decode_ms_median, r.decode_ms_mean, r.decode_wall_ms_median, r.decode_ms_p95);
  return s + "</tbody>\n</table>\n";
}

// The live-mode figures (bench_live.h): one row per setting, its goal
// marked met or not.
std::string live_table(const std::vector<LiveBenchRow>& rows) {
  std::string s =
      "<table>\n<thead><tr><th class=\"name\">mode</th><th class=\"name\">setting</th><th>CPU ms / frame<br>"
      "median</th><th>wall ms / frame<br>median</th><th>goal ms</th><th>frames measured</th><th>tracked</th>"
      "<th class=\"text\">stages (median wall ms)</th></tr></thead>\n<tbody>\n";
  for (const LiveBenchRow& r : rows) {
    std::string stages;
    for (const auto& [stage, ms] : r.stage_ms) stages += fmt::format("{}{} {:.1f}", stages.empty() ? "" : ", ", stage, ms);
    const std::string goal =
        r.goal_ms ? fmt::format("{:g} ({})", *r.goal_ms, r.goal_met() ? "met" : "not met") : "&ndash;";
    s += fmt::format(
        "<tr><td class=\"name\">{}</td><td class=\"name\">{}</td><td>{:.1f}</td><td>{:.1f}</td><td>{}</td>"
        "<td>{}/{}</td><td>{}</td><td class=\"text\">{}</td></tr>\n",
        html_escape(r.mode), html_escape(r.setting), r.cpu_ms_median, r.wall_ms_median, goal, r.measured, r.frames,
        r.tracked, html_escape(stages));
  }
  return s + "</tbody>\n</table>\n";
}

// Problems that differ only in their numbers (a chi^2, a count) are one.
std::string problem_kind(const std::string& problem) {
  std::string out;
  for (char c : problem)
    if (!std::isdigit(static_cast<unsigned char>(c)) && c != '.') out += c;
    else if (out.empty() || out.back() != '#') out += '#';
  return out;
}

// Captures that could not be measured, by scene and kind of problem, with
// the first problem of each kind verbatim.
std::string failures_table(const BenchResult& r) {
  struct Entry {
    std::string example;
    int n = 0;
  };
  std::map<std::pair<std::string, std::string>, Entry> groups;
  for (const BenchRow& row : r.rows)
    if (!row.usable && row.orientation == to_string(BarOrientation::horizontal_bars)) {
      Entry& e = groups[{row.scene, problem_kind(row.problem)}];
      if (e.n++ == 0) e.example = row.problem;
    }
  if (groups.empty()) return "<p class=\"note\">Every capture was measured.</p>\n";
  std::string s =
      "<table>\n<thead><tr><th class=\"name\">scene</th><th>measurements</th><th class=\"text\">problem (the "
      "first of its kind)</th></tr></thead>\n<tbody>\n";
  for (const auto& [key, e] : groups)
    s += fmt::format("<tr><td class=\"name\">{}</td><td>{}</td><td class=\"problem\">{}</td></tr>\n",
                     html_escape(key.first), e.n, html_escape(e.example));
  return s + "</tbody>\n</table>\n";
}

}  // namespace

std::string render_bench_html(const BenchResult& r, const HtmlReportOptions& options) {
  options.validate();
  const std::string chart_js = read_chart_js(options.chart_js, "bench.html");

  const BenchSummary* fastest = nullptr;
  const BenchSummary* most_accurate = nullptr;
  for (const BenchSummary& s : r.summaries) {
    if (s.sweep != "preset" || !s.median_abs_error_pct) continue;
    if (!fastest || s.ms_median < fastest->ms_median) fastest = &s;
    if (!most_accurate || *s.median_abs_error_pct < *most_accurate->median_abs_error_pct) most_accurate = &s;
  }
  int usable = 0;
  for (const BenchRow& row : r.rows) usable += row.usable && row.orientation == to_string(BarOrientation::horizontal_bars);

  // The kind of page (style, data id, charts) first; then this one's content.
  HtmlPage page{.css = kBenchCss, .data_id = "bench-data", .chart_script = kBenchChartScript};
  page.title = "tactres bench: what accuracy costs in time";
  page.heading = page.title;
  page.subtitle_html = fmt::format(
      "{} · {} scenes with known truth · {} measurements ({} usable) · camera: {} · machine: {} · tactres {}",
      r.quick ? "quick suite (--quick)" : "full suite", r.scenes, r.captures, usable, html_escape(r.camera),
      html_escape(r.machine), html_escape(options.tactres_version));
  page.tactres_version = options.tactres_version;
  page.data = page_data(r);

  std::string& s = page.body_html;
  s += "<section class=\"cards\">\n";
  s += fmt::format(
      "<div class=\"card\"><div class=\"k\">decode floor</div><div class=\"val\">{:.1f} <small>ms</small></div>"
      "<div class=\"detail\">OpenImageIO load_image, median CPU time of {}</div></div>\n",
      r.decode_ms_median, r.decodes);
  if (fastest)
    s += fmt::format(
        "<div class=\"card\"><div class=\"k\">fastest preset</div><div class=\"val\">{} <small>{:.1f} ms</small>"
        "</div><div class=\"detail\">median |error| {:.2f} %, p95 {}</div></div>\n",
        html_escape(fastest->setting), fastest->ms_median, *fastest->median_abs_error_pct,
        cell(fastest->p95_abs_error_pct, 1, 2, " %"));
  if (most_accurate)
    s += fmt::format(
        "<div class=\"card\"><div class=\"k\">most accurate preset</div><div class=\"val\">{} <small>{:.1f} ms"
        "</small></div><div class=\"detail\">median |error| {:.2f} %, p95 {}</div></div>\n",
        html_escape(most_accurate->setting), most_accurate->ms_median, *most_accurate->median_abs_error_pct,
        cell(most_accurate->p95_abs_error_pct, 1, 2, " %"));
  s += fmt::format(
      "<div class=\"card\"><div class=\"k\">run time</div><div class=\"val\">{:.0f} <small>s</small></div>"
      "<div class=\"detail\">render {:.0f} s, decode + analysis {:.0f} s</div></div>\n",
      r.wall_seconds, r.render_seconds, r.measure_seconds);
  s += "</section>\n";

  s += "<section id=\"pareto\">\n<h2>Accuracy versus time</h2>\n"
       "<div class=\"chart-box\"><canvas id=\"chart-pareto\" role=\"img\" aria-label=\"median error versus "
       "analysis time per setting, with the Pareto front\"></canvas></div>\n"
       "<p class=\"note\">Each point is a setting over every capture: the median analysis time of the usable "
       "captures (single-threaded, the thread's CPU time, which is what the work takes on an idle core even when "
       "the machine is shared) against the median |relative error| of the interpolated limit versus the "
       "truth, over scenes and orientations. Ringed and joined in red: the Pareto front (no other setting is both "
       "faster and more accurate). Dashed: the decode floor, the time OpenImageIO needs just to load the same "
       "files. The supersampling sweep changes the simulator, not the analysis, and is shown below.</p>\n"
       "</section>\n";

  s += "<section id=\"time\">\n<div class=\"pair\">\n"
       "<div><h2>Where the time goes</h2><div class=\"chart-box\"><canvas id=\"chart-stages\" role=\"img\" "
       "aria-label=\"median time per stage and setting\"></canvas></div></div>\n"
       "<div><h2>Simulator supersampling</h2><div class=\"chart-box\"><canvas id=\"chart-supersampling\" "
       "role=\"img\" aria-label=\"error and render time versus supersampling\"></canvas></div></div>\n"
       "</div>\n<p class=\"note\">Left: median wall-clock milliseconds per capture by stage, as the analysis "
       "reports them (the medians of each stage, so they need not add up to the median total), with the decode "
       "floor first. Right: the noise-free sweep "
       "scenes rendered at each supersampling value and measured with the balanced preset; a coarse render "
       "departs from the analytic truth, which assumes exact pixel integration.</p>\n</section>\n";

  s += "<section id=\"table\">\n<h2>Per setting</h2>\n<div class=\"scroll\">\n" + summary_table(r) + "</div>\n";
  s += "<ul class=\"note\">\n"
       "<li><b>|error|</b>: |measured / true &minus; 1| of the interpolated limit, over the orientations where "
       "both exist.</li>\n"
       "<li><b>interpolated limit reported</b>: of the orientations of usable captures with a true interpolated "
       "limit, the share for which the measurement gives one too (none: the crossing could not be bracketed, "
       "because the next finer element had a graded status). The error columns cover only these.</li>\n"
       "<li><b>discrete agreement</b>: the measured discrete limit (group and element) equals the true one, "
       "over the orientations of usable captures.</li>\n"
       "<li><b>2&sigma; coverage</b>: |measured &minus; true| &le; 2 &times; the reported 1&sigma; "
       "uncertainty; about 95 % if the uncertainty is right.</li>\n"
       "</ul>\n</section>\n";
  s += "<section id=\"failures\">\n<h2>Captures that could not be measured</h2>\n" + failures_table(r) +
       "</section>\n";
  if (!r.live.empty())
    s += "<section id=\"live\">\n<h2>Live mode (tactres watch)</h2>\n<p class=\"note\">A drifting "
         "through-focus sequence measured frame by frame, frames in memory, one thread; the median per frame "
         "after the first. Goals: issue #16's. Also in live.csv.</p>\n<div class=\"scroll\">\n" +
         live_table(r.live) + "</div>\n</section>\n";
  s += "<footer>\n<p>Every number on this page is in bench.csv (one row per capture, setting and orientation) "
       "and bench_summary.csv (the live figures in live.csv); docs/BENCH.md describes the columns and the suite. Charts: Chart.js (MIT "
       "licence), inlined; the page needs no network.</p>\n</footer>\n";
  return render_html_page(page, chart_js);
}

}  // namespace tactres
