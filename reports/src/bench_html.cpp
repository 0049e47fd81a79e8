#include "tactres/reports/bench_html.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "tactres/targets/atomic_file.h"

namespace tactres {
namespace {

using nlohmann::json;

// The report page's look (report_html.cpp): same palette and card/table
// style, so that bench.html and report.html read as one family.
constexpr const char* kBenchCss = R"CSS(
:root { --ink: #1d2330; --muted: #5b6472; --line: #d9dde3; --bg: #f5f6f8; --card: #fff;
        --ok: #2e7d32; --bad: #b3261e; --front: #b3261e; }
* { box-sizing: border-box; }
html { background: var(--bg); }
body { margin: 0 auto; max-width: 1240px; padding: 24px 28px 40px; color: var(--ink);
       font: 14px/1.45 "DejaVu Sans", "Segoe UI", Roboto, "Helvetica Neue", Arial, sans-serif; }
h1 { font-size: 24px; margin: 0 0 4px; letter-spacing: -0.01em; }
h2 { font-size: 17px; margin: 0 0 10px; }
.sub { color: var(--muted); margin: 0 0 18px; }
section { background: var(--card); border: 1px solid var(--line); border-radius: 8px; padding: 16px 18px;
          margin: 0 0 18px; }
.cards { display: grid; grid-template-columns: repeat(auto-fit, minmax(220px, 1fr)); gap: 12px;
         background: none; border: none; padding: 0; }
.card { background: var(--card); border: 1px solid var(--line); border-radius: 8px; padding: 12px 14px; }
.card .k { color: var(--muted); font-size: 12px; text-transform: uppercase; letter-spacing: 0.04em; }
.card .val { font-size: 20px; font-weight: 600; margin-top: 2px; }
.card .val small { font-size: 13px; font-weight: 400; color: var(--muted); }
.card .detail { color: var(--muted); font-size: 12px; margin-top: 2px; }
table { border-collapse: collapse; width: 100%; font-variant-numeric: tabular-nums; }
th, td { padding: 5px 8px; border-bottom: 1px solid var(--line); text-align: right; white-space: nowrap; }
th { font-size: 12px; color: var(--muted); font-weight: 600; vertical-align: bottom; }
td.name, th.name { text-align: left; font-weight: 600; }
td.text, th.text { text-align: left; white-space: normal; }
tbody tr:nth-child(even) { background: #fafbfc; }
tr.front td.name::after { content: "Pareto"; margin-left: 8px; font-size: 11px; font-weight: 400; color: #fff;
                          background: var(--front); border-radius: 3px; padding: 1px 5px; }
tr.floor td { color: var(--muted); font-style: italic; }
td.problem { text-align: left; white-space: normal; color: var(--bad); }
.note { color: var(--muted); font-size: 12.5px; margin: 8px 0 0; }
.scroll { overflow-x: auto; }
.note li { margin: 2px 0; }
.chart-box { position: relative; height: 440px; }
.pair { display: grid; grid-template-columns: 1fr 1fr; gap: 18px; }
.pair .chart-box { height: 360px; }
#script-error { background: #fdecea; color: var(--bad); border: 1px solid #f5c2bd; padding: 10px 14px;
                border-radius: 6px; margin: 0 0 18px; }
footer { color: var(--muted); font-size: 12px; }
@media (max-width: 900px) { .pair { grid-template-columns: 1fr; } }
@media print {
  @page { size: A4 landscape; margin: 12mm; }
  html, body { background: #fff; }
  body { max-width: none; padding: 0; font-size: 10.5pt; }
  section { border: none; padding: 0; margin: 0 0 10mm; break-inside: avoid; }
  .chart-box { height: 85mm; }
  canvas { max-width: 100% !important; }
  tr { break-inside: avoid; }
  #script-error { display: none; }
}
)CSS";

// Draws the three charts from the inline JSON and counts them on <body>
// (data-charts-rendered), as the report page does.
constexpr const char* kBenchScript = R"JS(
(function () {
  'use strict';
  var body = document.body;
  function fail(e) {
    var msg = String((e && e.message) || e);
    body.setAttribute('data-script-error', msg);
    var box = document.getElementById('script-error');
    if (box) { box.hidden = false; box.textContent = 'The charts could not be drawn: ' + msg; }
  }
  try {
    if (typeof Chart === 'undefined') throw new Error('Chart.js is missing from this file');
    var data = JSON.parse(document.getElementById('bench-data').textContent);
    Chart.defaults.font.family = getComputedStyle(body).fontFamily;
    Chart.defaults.font.size = 12;
    Chart.defaults.color = '#333';
    Chart.defaults.animation = false;
    Chart.defaults.maintainAspectRatio = false;

    var rendered = 0;
    Chart.register({
      id: 'renderedCounter',
      afterRender: function (chart) {
        if (chart.$tactresCounted || !(chart.width > 0 && chart.height > 0)) return;
        chart.$tactresCounted = true;
        chart.canvas.setAttribute('data-rendered-size', chart.width + 'x' + chart.height);
        body.setAttribute('data-charts-rendered', String(++rendered));
      }
    });
    // dataset.pointLabels[i]: text beside point i.
    var pointLabels = {
      id: 'pointLabels',
      afterDatasetsDraw: function (chart) {
        var ctx = chart.ctx;
        ctx.save();
        ctx.font = '11px ' + Chart.defaults.font.family;
        ctx.textBaseline = 'middle';
        chart.data.datasets.forEach(function (ds, di) {
          if (!ds.pointLabels || !chart.isDatasetVisible(di)) return;
          chart.getDatasetMeta(di).data.forEach(function (el, i) {
            if (!ds.pointLabels[i]) return;
            ctx.fillStyle = ds.borderColor;
            ctx.fillText(ds.pointLabels[i], el.x + 8, el.y - 8);
          });
        });
        ctx.restore();
      }
    };

    var colours = {preset: '#1d2330', bin_px: '#0072b2', fit_psf_shape: '#d55e00',
                   pose_boundary_points: '#009e73', supersampling: '#cc79a7'};
    var analysis = data.settings.filter(function (s) { return s.sweep !== 'supersampling'; });
    var measured = analysis.filter(function (s) { return s.median_error_pct !== null; });
    var sweeps = [];
    measured.forEach(function (s) { if (sweeps.indexOf(s.sweep) < 0) sweeps.push(s.sweep); });
    var yMax = Math.max.apply(null, measured.map(function (s) { return s.median_error_pct; }).concat([0.1])) * 1.15;
    var datasets = sweeps.map(function (sw) {
      var pts = measured.filter(function (s) { return s.sweep === sw; });
      return {
        label: sw === 'preset' ? 'presets' : 'balanced, ' + sw + ' varied',
        data: pts.map(function (s) { return {x: s.ms_median, y: s.median_error_pct, s: s}; }),
        // Presets and front points are named; the rest on hover (they crowd).
        pointLabels: pts.map(function (s) { return s.sweep === 'preset' || s.pareto ? s.label : ''; }),
        backgroundColor: colours[sw] || '#7f7f7f', borderColor: colours[sw] || '#7f7f7f',
        pointRadius: sw === 'preset' ? 7 : 5, pointStyle: sw === 'preset' ? 'rectRot' : 'circle',
        showLine: false
      };
    });
    var front = measured.filter(function (s) { return s.pareto; })
                        .sort(function (a, b) { return a.ms_median - b.ms_median; });
    datasets.push({
      label: 'Pareto front', data: front.map(function (s) { return {x: s.ms_median, y: s.median_error_pct, s: s}; }),
      showLine: true, borderColor: '#b3261e', backgroundColor: 'rgba(0,0,0,0)', borderWidth: 2,
      pointRadius: 11, pointBorderWidth: 2, pointStyle: 'circle', stepped: false
    });
    if (data.decode_ms_median > 0)
      datasets.push({
        label: 'decode floor (load_image)', data: [{x: data.decode_ms_median, y: 0}, {x: data.decode_ms_median, y: yMax}],
        showLine: true, borderColor: '#5b6472', borderDash: [6, 4], borderWidth: 1.5, pointRadius: 0
      });
    new Chart(document.getElementById('chart-pareto'), {
      type: 'scatter',
      data: {datasets: datasets},
      options: {
        scales: {
          x: {min: 0, title: {display: true, text: 'analysis time per capture: median thread CPU time (ms, single-threaded)'}},
          y: {min: 0, max: yMax, title: {display: true, text: 'median |error| of the interpolated limit (%)'}}
        },
        plugins: {
          tooltip: {callbacks: {label: function (ctx) {
            var s = ctx.raw.s;
            if (!s) return 'decode floor: ' + data.decode_ms_median.toFixed(1) + ' ms';
            return s.setting + ': ' + s.ms_median.toFixed(1) + ' ms, median |e| ' + s.median_error_pct.toFixed(2) +
                   ' %, p95 ' + s.p95_error_pct.toFixed(2) + ' %';
          }}}
        }
      },
      plugins: [pointLabels]
    });

    // Where the time goes: decode, then the analysis stages, per setting.
    var stages = [['decode (load_image)', 'decode_ms', '#bdbdbd'], ['locate fiducials', 'locate_fiducials_ms', '#0072b2'],
                  ['pose', 'pose_ms', '#56b4e9'], ['reference patch', 'reference_patch_ms', '#009e73'],
                  ['profiles', 'profiles_ms', '#e69f00'], ['fits', 'fits_ms', '#d55e00'],
                  ['decide', 'decide_ms', '#cc79a7'], ['other', 'other_ms', '#7f7f7f']];
    var timed = analysis.filter(function (s) { return s.usable_captures > 0; });
    new Chart(document.getElementById('chart-stages'), {
      type: 'bar',
      data: {
        labels: timed.map(function (s) { return s.setting; }),
        datasets: stages.map(function (st) {
          return {label: st[0], backgroundColor: st[2],
                  data: timed.map(function (s) { return st[1] === 'decode_ms' ? data.decode_wall_ms_median : s.stages[st[1]]; })};
        })
      },
      options: {
        indexAxis: 'y',
        scales: {x: {stacked: true, title: {display: true, text: 'median wall-clock ms per capture'}}, y: {stacked: true}}
      }
    });

    // The simulator: error versus supersampling, with its render time.
    var ss = data.settings.filter(function (s) { return s.sweep === 'supersampling'; });
    new Chart(document.getElementById('chart-supersampling'), {
      type: 'bar',
      data: {
        labels: ss.map(function (s) { return s.label; }),
        datasets: [
          {label: 'median |error| (%)', data: ss.map(function (s) { return s.median_error_pct; }),
           backgroundColor: '#cc79a7', yAxisID: 'y'},
          {label: 'p95 |error| (%)', data: ss.map(function (s) { return s.p95_error_pct; }),
           backgroundColor: '#e7b7d3', yAxisID: 'y'},
          {label: 'render time (ms)', type: 'line', data: ss.map(function (s) { return s.render_ms_median; }),
           borderColor: '#1d2330', backgroundColor: '#1d2330', yAxisID: 'y2'}
        ]
      },
      options: {
        scales: {
          y: {min: 0, position: 'left', title: {display: true, text: '|error| of the interpolated limit (%)'}},
          y2: {min: 0, position: 'right', grid: {drawOnChartArea: false}, title: {display: true, text: 'render ms'}}
        }
      }
    });
  } catch (e) {
    fail(e);
  }
})();
)JS";

// JSON inside <script>: "<" becomes \u003c, so nothing can close the element.
std::string script_safe_json(const json& j) {
  std::string out;
  for (char ch : j.dump()) {
    if (ch == '<') out += "\\u003c";
    else out += ch;
  }
  return out;
}

// Inlined JavaScript must not contain "</script" (any case).
std::string script_safe_js(std::string js) {
  for (size_t pos = 0; (pos = js.find("</", pos)) != std::string::npos; pos += 2) {
    std::string tag = js.substr(pos + 2, 6);
    std::transform(tag.begin(), tag.end(), tag.begin(), [](unsigned char ch) { return char(std::tolower(ch)); });
    if (tag == "script") js.replace(pos, 2, "<\\/");
  }
  return js;
}

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
  std::string chart_js;
  try {
    chart_js = read_file(options.chart_js);
  } catch (const std::runtime_error&) {
    throw std::runtime_error(fmt::format(
        "cannot read Chart.js at {}: bench.html inlines it so that the page opens offline; install Debian's "
        "libjs-chart.js (bash scripts/install-deps.sh)",
        options.chart_js.string()));
  }
  if (chart_js.find("Chart") == std::string::npos)
    throw std::runtime_error(options.chart_js.string() + " does not look like Chart.js (no \"Chart\" in it)");

  const BenchSummary* fastest = nullptr;
  const BenchSummary* most_accurate = nullptr;
  for (const BenchSummary& s : r.summaries) {
    if (s.sweep != "preset" || !s.median_abs_error_pct) continue;
    if (!fastest || s.ms_median < fastest->ms_median) fastest = &s;
    if (!most_accurate || *s.median_abs_error_pct < *most_accurate->median_abs_error_pct) most_accurate = &s;
  }
  int usable = 0;
  for (const BenchRow& row : r.rows) usable += row.usable && row.orientation == to_string(BarOrientation::horizontal_bars);

  std::string s;
  s.reserve(chart_js.size() + 100000);
  s += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
       "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n";
  s += fmt::format("<meta name=\"generator\" content=\"tactres {}\">\n", html_escape(options.tactres_version));
  s += "<title>tactres bench: what accuracy costs in time</title>\n";
  s += "<style>" + std::string(kBenchCss) + "</style>\n</head>\n";
  s += "<body data-charts-expected=\"3\" data-charts-rendered=\"0\">\n";
  s += "<header>\n<h1>tactres bench: what accuracy costs in time</h1>\n";
  s += fmt::format(
      "<p class=\"sub\">{} · {} scenes with known truth · {} measurements ({} usable) · camera: {} · machine: {} · "
      "tactres {}</p>\n</header>\n",
      r.quick ? "quick suite (--quick)" : "full suite", r.scenes, r.captures, usable, html_escape(r.camera),
      html_escape(r.machine), html_escape(options.tactres_version));
  s += "<div id=\"script-error\" hidden></div>\n";

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
  s += "<footer>\n<p>Every number on this page is in bench.csv (one row per capture, setting and orientation) "
       "and bench_summary.csv; docs/BENCH.md describes the columns and the suite. Charts: Chart.js (MIT "
       "licence), inlined; the page needs no network.</p>\n</footer>\n";
  s += "<script type=\"application/json\" id=\"bench-data\">" + script_safe_json(page_data(r)) + "</script>\n";
  s += "<script>\n" + script_safe_js(std::move(chart_js)) + "\n</script>\n";
  s += "<script>" + std::string(kBenchScript) + "</script>\n</body>\n</html>\n";
  return s;
}

}  // namespace tactres
