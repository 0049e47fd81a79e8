#include "tactres/reports/html_page.h"

#include <doctest/doctest.h>

#include <iterator>
#include <regex>
#include <stdexcept>
#include <string>

#include "test_measurements.h"

namespace tactres {
namespace {

using testing::ReportTempDir;

HtmlPage sample_page() {
  HtmlPage p;
  p.title = "A & B <page>";
  p.heading = "Heading <h>";
  p.subtitle_html = "sub <b>bold</b>";
  p.tactres_version = "1.2.3";
  p.css = ".only-here { color: red; }\n";
  p.body_html = "<section id=\"content\">BODY<canvas id=\"c1\"></canvas><canvas id=\"c2\"></canvas></section>\n";
  p.data_id = "my-data_1";
  p.data = {{"label", "</script><b>"}, {"n", 3}};
  p.chart_script = "drawCharts(data, body);";
  p.after_script = "afterCharts();";
  return p;
}

TEST_CASE("html_escape escapes markup and quotes") {
  CHECK(html_escape("<a href=\"x\">T&C's</a>") == "&lt;a href=&quot;x&quot;&gt;T&amp;C&#39;s&lt;/a&gt;");
  CHECK(html_escape("plain") == "plain");
}

TEST_CASE("script_safe_json: '<' becomes \\u003c, the same JSON value") {
  const nlohmann::json j = {{"a", "</script><!--"}, {"b", 1.5}};
  const std::string safe = script_safe_json(j);
  CHECK(safe.find('<') == std::string::npos);
  CHECK(safe.find("\\u003c/script>") != std::string::npos);
  CHECK(nlohmann::json::parse(safe) == j);
}

TEST_CASE("script_safe_js: only </script (any case) is rewritten") {
  CHECK(script_safe_js("a('</script>'); b('</ScRiPt >')") == "a('<\\/script>'); b('<\\/ScRiPt >')");
  CHECK(script_safe_js("x = '</div>' + '</scrip' + '</'") == "x = '</div>' + '</scrip' + '</'");
}

TEST_CASE("render_html_page: one self-contained document in the shared frame") {
  const HtmlPage p = sample_page();
  const std::string html = render_html_page(p, "/* chart */ window.Chart = 1; var s = '</script>';");
  CHECK(html.rfind("<!DOCTYPE html>\n<html lang=\"en\">", 0) == 0);
  CHECK(html.find("<meta name=\"generator\" content=\"tactres 1.2.3\">") != std::string::npos);
  CHECK(html.find("<title>A &amp; B &lt;page&gt;</title>") != std::string::npos);
  CHECK(html.find("<h1>Heading &lt;h&gt;</h1>\n<p class=\"sub\">sub <b>bold</b></p>") != std::string::npos);
  // One chart expected per canvas.
  CHECK(html.find("<body data-charts-expected=\"2\" data-charts-rendered=\"0\">") != std::string::npos);
  HtmlPage no_charts = p;
  no_charts.body_html = "<p>text only</p>\n";
  CHECK(render_html_page(no_charts, "Chart").find("<body data-charts-expected=\"0\"") != std::string::npos);

  // The shared stylesheet first, the page's rules after it (they win ties).
  const size_t base_css = html.find("#script-error { background:");
  const size_t page_css = html.find(".only-here { color: red; }");
  const size_t style_end = html.find("</style>");
  REQUIRE(base_css != std::string::npos);
  REQUIRE(page_css != std::string::npos);
  CHECK(base_css < page_css);
  CHECK(page_css < style_end);

  // The error box the script fills, then the page's body.
  const size_t error_box = html.find("<div id=\"script-error\" hidden></div>");
  const size_t body = html.find("<section id=\"content\">BODY<canvas");
  REQUIRE(error_box != std::string::npos);
  REQUIRE(body != std::string::npos);
  CHECK(error_box < body);

  // Three scripts: the data, Chart.js, the page script; nothing inside any
  // of them can end one early.
  auto matches = [&](const char* pattern) {
    const std::regex re(pattern);
    return std::distance(std::sregex_iterator(html.begin(), html.end(), re), std::sregex_iterator());
  };
  CHECK(matches("</script>") == 3);
  CHECK(matches("<script[ >]") == 3);
  CHECK(html.find("<script type=\"application/json\" id=\"my-data_1\">{\"label\":\"\\u003c/script>\\u003cb>\",\"n\":3}"
                  "</script>") != std::string::npos);
  CHECK(html.find("/* chart */ window.Chart = 1; var s = '<\\/script>';") != std::string::npos);
  CHECK(body < html.find("<script"));
  CHECK(html.find("<link") == std::string::npos);
  CHECK(html.find(" src=") == std::string::npos);
}

TEST_CASE("render_html_page: the page's chart code runs inside the shared prologue") {
  const std::string html = render_html_page(sample_page(), "window.Chart = 1;");
  const size_t script = html.rfind("<script>");
  REQUIRE(script != std::string::npos);
  const std::string js = html.substr(script);
  const size_t parse = js.find("JSON.parse(document.getElementById('my-data_1').textContent)");
  const size_t counter = js.find("body.setAttribute('data-charts-rendered', String(++rendered))");
  const size_t charts = js.find("drawCharts(data, body);");
  const size_t caught = js.find("} catch (e) {\n    fail(e);\n  }");
  const size_t after = js.find("afterCharts();");
  const size_t end = js.find("})();");
  REQUIRE(parse != std::string::npos);
  REQUIRE(counter != std::string::npos);
  REQUIRE(charts != std::string::npos);
  REQUIRE(caught != std::string::npos);
  REQUIRE(after != std::string::npos);
  REQUIRE(end != std::string::npos);
  CHECK(js.find("try {") < parse);
  CHECK(parse < counter);
  CHECK(counter < charts);
  CHECK(js.find("function textLabels(") < charts);  // the shared label plugin is there for the charts
  CHECK(charts < caught);
  CHECK(caught < after);
  CHECK(after < end);
  CHECK(js.find("body.setAttribute('data-script-error', msg)") < js.find("try {"));
}

TEST_CASE("HtmlPage::validate refuses what would break the page") {
  HtmlPage p = sample_page();
  CHECK_NOTHROW(p.validate());
  p.data_id = "x'); alert(1); ('";
  CHECK_THROWS_AS(render_html_page(p, "Chart"), std::invalid_argument);
  p.data_id = "";
  CHECK_THROWS_AS(p.validate(), std::invalid_argument);
  p = sample_page();
  p.title = "";
  CHECK_THROWS_AS(p.validate(), std::invalid_argument);
  p = sample_page();
  p.css = "a { color: red; } </STYLE><script>";
  CHECK_THROWS_AS(p.validate(), std::invalid_argument);
}

TEST_CASE("read_chart_js: the file, or an error that says how to get it") {
  ReportTempDir dir("reports-html-page");
  const auto good = dir.write("chart.min.js", "/*! Chart.js v4 */ window.Chart = function () {};");
  CHECK(read_chart_js(good, "page.html") == "/*! Chart.js v4 */ window.Chart = function () {};");

  try {
    read_chart_js(dir.path / "missing.js", "page.html", "give its path with --chart-js");
    FAIL("no error for a missing Chart.js");
  } catch (const std::runtime_error& e) {
    const std::string m = e.what();
    CHECK(m.find("missing.js") != std::string::npos);
    CHECK(m.find("page.html inlines it") != std::string::npos);
    CHECK(m.find("libjs-chart.js") != std::string::npos);
    CHECK(m.find(" or give its path with --chart-js") != std::string::npos);
  }
  try {
    read_chart_js(dir.path / "missing.js", "page.html");
    FAIL("no error for a missing Chart.js");
  } catch (const std::runtime_error& e) {
    CHECK(std::string(e.what()).find(" or ") == std::string::npos);
  }

  const auto other = dir.write("other.js", "console.log('not it');");
  CHECK_THROWS_WITH_AS(read_chart_js(other, "page.html"), doctest::Contains("does not look like Chart.js"),
                       std::runtime_error);
}

}  // namespace
}  // namespace tactres
