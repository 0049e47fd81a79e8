#include "tactres/reports/html_page.h"

#include <algorithm>
#include <cctype>
#include <stdexcept>

#include <fmt/format.h>

#include "tactres/util/atomic_file.h"

namespace tactres {
namespace {

// The look both pages share, so that report.html and bench.html read as one
// family: palette, type, cards, tables, notes, the error box and the print
// layout. Chart heights are left to the pages: each sizes its own charts, on
// screen and in print.
constexpr const char* kBaseCss = R"CSS(
:root { --ink: #1d2330; --muted: #5b6472; --line: #d9dde3; --bg: #f5f6f8; --card: #fff;
        --ok: #2e7d32; --bad: #b3261e; }
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
tbody tr:nth-child(even) { background: #fafbfc; }
td.problem { text-align: left; white-space: normal; color: var(--bad); }
.note { color: var(--muted); font-size: 12.5px; margin: 8px 0 0; }
.note li { margin: 2px 0; }
.chart-box { position: relative; }
#script-error { background: #fdecea; color: var(--bad); border: 1px solid #f5c2bd; padding: 10px 14px;
                border-radius: 6px; margin: 0 0 18px; }
footer { color: var(--muted); font-size: 12px; }
@media print {
  @page { size: A4 landscape; margin: 12mm; }
  html, body { background: #fff; }
  body { max-width: none; padding: 0; font-size: 10.5pt; }
  section { border: none; padding: 0; }
  canvas { max-width: 100% !important; }
  tr { break-inside: avoid; }
  #script-error { display: none; }
}
)CSS";

// The page script around the page's own chart code. Chart.js's defaults
// match the page's type; animation is off so that a chart is final when it
// first renders, which is when the counter plugin counts it (the browser
// tests wait for data-charts-rendered to reach data-charts-expected).
constexpr const char* kScriptBeforeCharts = R"JS(
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
    var data = JSON.parse(document.getElementById('{data_id}').textContent);
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

    // A Chart.js plugin that writes dataset[id][i], where there is one, in
    // the dataset's colour at place(chart, dataset, meta, element, i): an
    // [x, y] in pixels, or null for none.
    function textLabels(id, font, align, baseline, place) {
      return {
        id: id,
        afterDatasetsDraw: function (chart) {
          var ctx = chart.ctx;
          ctx.save();
          ctx.font = font + ' ' + Chart.defaults.font.family;
          ctx.textAlign = align;
          ctx.textBaseline = baseline;
          chart.data.datasets.forEach(function (ds, di) {
            if (!ds[id] || !chart.isDatasetVisible(di)) return;
            var meta = chart.getDatasetMeta(di);
            meta.data.forEach(function (el, i) {
              var at = ds[id][i] ? place(chart, ds, meta, el, i) : null;
              if (!at) return;
              ctx.fillStyle = ds.borderColor;
              ctx.fillText(ds[id][i], at[0], at[1]);
            });
          });
          ctx.restore();
        }
      };
    }
)JS";

constexpr const char* kScriptAfterCharts = R"JS(
  } catch (e) {
    fail(e);
  }
)JS";

std::string lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char ch) { return char(std::tolower(ch)); });
  return out;
}

// One chart per canvas: what the page must have drawn once it has loaded.
int count_charts(std::string_view body_html) {
  int n = 0;
  for (size_t pos = 0; (pos = body_html.find("<canvas", pos)) != std::string_view::npos; pos += 7) ++n;
  return n;
}

}  // namespace

void HtmlPage::validate() const {
  if (title.empty()) throw std::invalid_argument("the HTML page has no title");
  if (data_id.empty() || !std::all_of(data_id.begin(), data_id.end(), [](unsigned char ch) {
        return std::isalnum(ch) || ch == '-' || ch == '_';
      }))
    throw std::invalid_argument(fmt::format(
        "the page's data id \"{}\" must be non-empty and only letters, digits, '-' and '_' (it is an element id "
        "that the page script names)",
        data_id));
  // The stylesheet sits inside <style>, which "</style" would end.
  if (lower(css).find("</style") != std::string::npos)
    throw std::invalid_argument("the page's CSS contains \"</style\", which would end the stylesheet early");
}

std::string read_chart_js(const std::filesystem::path& path, std::string_view page, std::string_view alternative) {
  std::string js;
  try {
    js = read_file(path);
  } catch (const std::runtime_error&) {
    throw std::runtime_error(fmt::format(
        "cannot read Chart.js at {}: {} inlines it so that the page opens offline; install Debian's libjs-chart.js "
        "(bash scripts/install-deps.sh){}{}",
        path.string(), page, alternative.empty() ? "" : " or ", alternative));
  }
  if (js.find("Chart") == std::string::npos)
    throw std::runtime_error(path.string() + " does not look like Chart.js (no \"Chart\" in it)");
  return js;
}

std::string render_html_page(const HtmlPage& page, std::string_view chart_js) {
  page.validate();
  std::string script = kScriptBeforeCharts;
  const std::string placeholder = "{data_id}";  // validate(): the id needs no escaping in a JS string
  script.replace(script.find(placeholder), placeholder.size(), page.data_id);
  script += page.chart_script;
  if (script.back() != '\n') script += '\n';
  script += kScriptAfterCharts;
  script += page.after_script;
  if (script.back() != '\n') script += '\n';
  script += "})();\n";

  std::string s;
  s.reserve(chart_js.size() + page.body_html.size() + page.css.size() + script.size() + 20000);
  s += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
       "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n";
  s += fmt::format("<meta name=\"generator\" content=\"tactres {}\">\n", html_escape(page.tactres_version));
  s += fmt::format("<title>{}</title>\n", html_escape(page.title));
  s += "<style>" + std::string(kBaseCss) + page.css + "</style>\n</head>\n";
  s += fmt::format("<body data-charts-expected=\"{}\" data-charts-rendered=\"0\">\n", count_charts(page.body_html));
  s += fmt::format("<header>\n<h1>{}</h1>\n<p class=\"sub\">{}</p>\n</header>\n", html_escape(page.heading),
                   page.subtitle_html);
  s += "<div id=\"script-error\" hidden></div>\n";
  s += page.body_html;
  s += fmt::format("<script type=\"application/json\" id=\"{}\">", page.data_id) + script_safe_json(page.data) +
       "</script>\n";
  s += "<script>\n" + script_safe_js(std::string(chart_js)) + "\n</script>\n";
  s += "<script>" + script_safe_js(std::move(script)) + "</script>\n</body>\n</html>\n";
  return s;
}

std::string html_escape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char ch : text) {
    switch (ch) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += ch;
    }
  }
  return out;
}

std::string script_safe_json(const nlohmann::json& j) {
  const std::string s = j.dump();
  std::string out;
  out.reserve(s.size());
  for (char ch : s) {
    if (ch == '<') out += "\\u003c";
    else out += ch;
  }
  return out;
}

std::string script_safe_js(std::string js) {
  for (size_t pos = 0; (pos = js.find("</", pos)) != std::string::npos; pos += 2)
    if (lower(std::string_view(js).substr(pos + 2, 6)) == "script") js.replace(pos, 2, "<\\/");
  return js;
}

}  // namespace tactres
