#pragma once
// The page machinery that `tactres report` (report_html.h) and `tactres
// bench` (bench_html.h) share: one self-contained HTML document with the
// shared stylesheet, the inline JSON data, Chart.js inlined (so that the page
// opens offline) and the page script's prologue, which the browser tests and
// the pages' users rely on:
//   - <body data-charts-expected="N" data-charts-rendered="0">: N is the
//     number of <canvas> elements in the body, one per chart; a Chart.js
//     plugin counts each chart that has drawn at a non-zero size into
//     data-charts-rendered and sets data-rendered-size="WxH" on its canvas;
//   - on any error in the chart script (Chart.js missing, bad data, a throw)
//     <body data-script-error="..."> is set and #script-error shows it.

#include <filesystem>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace tactres {

// Where Debian's libjs-chart.js installs the minified UMD build
// (`dpkg -L libjs-chart.js`).
inline constexpr const char* kDebianChartJsPath = "/usr/share/javascript/chart.js/chart.min.js";

struct HtmlPage {
  // Every member has an initializer, so that a page can name just the
  // members it sets in a designated initializer (-Wmissing-field-initializers).
  std::string title{};            // <title>, plain text
  std::string heading{};          // <h1>, plain text
  std::string subtitle_html{};    // the line under the heading; markup, so escape what goes into it
  std::string tactres_version{};  // <meta name="generator">
  // Page-specific CSS, after the shared stylesheet: its rules win ties with
  // the shared ones. A page that changes a property that the shared print
  // rules set must set it again in its own @media print block.
  std::string css{};
  // Everything after the header and the #script-error box: sections, footer,
  // and a <canvas> for each chart that chart_script draws.
  std::string body_html{};
  std::string data_id{};  // id of the inline JSON element: letters, digits, '-' and '_'
  nlohmann::json data{};
  // JavaScript run inside the shared prologue's try block, after Chart.js's
  // defaults are set. In scope: `data` (the parsed JSON), `body`, `fail(e)`
  // and textLabels(id, font, align, baseline, place), a Chart.js plugin that
  // writes dataset[id][i] at place(chart, dataset, meta, element, i) ([x, y]
  // in pixels, or null). Whatever it throws ends up in data-script-error.
  std::string chart_script{};
  // JavaScript run after that, whether or not the charts could be drawn
  // (what the page does without Chart.js, e.g. click handlers).
  std::string after_script{};

  void validate() const;  // throws std::invalid_argument
};

// Reads the Chart.js source to inline. Throws std::runtime_error naming the
// path and saying how to install it when it cannot be read: `page` names what
// inlines it ("bench.html"), `alternative` is another way out (or empty).
std::string read_chart_js(const std::filesystem::path& path, std::string_view page, std::string_view alternative = {});

// The complete document, with `chart_js` (the Chart.js source) inlined.
std::string render_html_page(const HtmlPage& page, std::string_view chart_js);

// Escapes &, <, >, " and ' for HTML text and attribute values.
std::string html_escape(std::string_view text);

// JSON that can sit inside <script>: "<" only occurs in strings, where
// \u003c is the same character, so nothing in it can close the element.
std::string script_safe_json(const nlohmann::json& j);

// JavaScript that can sit inside <script>: "</script" (any case) becomes
// "<\/script", which means the same inside a JS string or regex.
std::string script_safe_js(std::string js);

}  // namespace tactres
