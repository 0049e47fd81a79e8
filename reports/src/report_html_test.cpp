#include "tactres/reports/report_html.h"

#include <doctest/doctest.h>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <opencv2/core.hpp>

#include <regex>
#include <string>

#include "tactres/camera/image_io.h"
#include "tactres/util/atomic_file.h"
#include "test_measurements.h"

namespace tactres {
namespace {

namespace fs = std::filesystem;
using testing::HandMeasurement;
using testing::hand_measurement;
using testing::ReportTempDir;

std::string base64_decode(const std::string& s) {
  static const std::string kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  unsigned v = 0;
  int bits = 0;
  for (char ch : s) {
    if (ch == '=') break;
    v = v << 6 | unsigned(kAlphabet.find(ch));
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += char(v >> bits & 0xff);
    }
  }
  return out;
}

size_t count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t pos = 0; (pos = text.find(what, pos)) != std::string::npos; pos += what.size()) ++n;
  return n;
}

TEST_CASE("base64 follows RFC 4648 (its test vectors)") {
  CHECK(base64_encode("") == "");
  CHECK(base64_encode("f") == "Zg==");
  CHECK(base64_encode("fo") == "Zm8=");
  CHECK(base64_encode("foo") == "Zm9v");
  CHECK(base64_encode("foob") == "Zm9vYg==");
  CHECK(base64_encode("fooba") == "Zm9vYmE=");
  CHECK(base64_encode("foobar") == "Zm9vYmFy");
  CHECK(base64_encode(std::string("\xff\x00\xfe", 3)) == "/wD+");
}

TEST_CASE("thumbnails: small PNGs as they are, large ones downscaled, missing ones explained") {
  ReportTempDir dir("reports-thumb");
  cv::Mat big(500, 1000, CV_8UC3, cv::Scalar(30, 120, 220));
  write_image(dir.path / "big.png", big);
  std::string why;
  const auto uri = thumbnail_data_uri(dir.path / "big.png", 200, &why);
  REQUIRE(uri);
  const std::string prefix = "data:image/jpeg;base64,";
  REQUIRE(uri->rfind(prefix, 0) == 0);
  const std::string jpeg = base64_decode(uri->substr(prefix.size()));
  OIIO::Filesystem::IOMemReader mem(jpeg.data(), jpeg.size());
  auto in = OIIO::ImageInput::open("thumb.jpg", nullptr, &mem);
  REQUIRE(in);
  CHECK(in->spec().width == 200);
  CHECK(in->spec().height == 100);

  cv::Mat small(60, 80, CV_8UC3, cv::Scalar(0, 0, 0));
  write_image(dir.path / "small.png", small);
  const auto small_uri = thumbnail_data_uri(dir.path / "small.png", 200, &why);
  REQUIRE(small_uri);
  CHECK(*small_uri == "data:image/png;base64," + base64_encode(read_file(dir.path / "small.png")));

  CHECK_FALSE(thumbnail_data_uri(dir.path / "none.png", 200, &why));
  CHECK(why.find("none.png is missing") != std::string::npos);
  dir.write("garbage.png", "not a png at all");
  CHECK_FALSE(thumbnail_data_uri(dir.path / "garbage.png", 200, &why));
  CHECK(why.find("garbage.png cannot be decoded") != std::string::npos);
}

struct Page {
  ReportTempDir dir{"reports-html"};
  Comparison comparison;
  HtmlReportOptions options;
  Page() {
    HandMeasurement ref, a, b, failed;
    ref.design = "cmos";
    ref.h.interp = 8.0;
    ref.v.interp = 10.0;
    a.design = "T<1>";  // markup in a label must come out as text
    a.h.interp = 6.0;
    a.v.interp = 5.0;
    b.design = "T2";
    b.h.interp = 4.0;
    b.v.interp = 4.5;
    failed.design = "T3";
    failed.usable = false;
    failed.problem = "no target found </script>";
    auto save = [&](const HandMeasurement& m, const std::string& name) {
      return measurement_from_json(hand_measurement(m), (dir.path / name).string());
    };
    cv::Mat overlay(50, 80, CV_8UC3, cv::Scalar(0, 200, 0));
    write_image(dir.path / "a.overlay.png", overlay);
    comparison = compare_designs({save(a, "a.json"), save(b, "b.json"), save(failed, "t3.json")}, save(ref, "cmos.json"));
    options.chart_js = dir.write("chart.min.js", "/* stand-in */ window.Chart = function () {};");
    options.tactres_version = "9.8.7";
  }
};

TEST_CASE("the HTML page: one row per design plus the reference, inline data, no external resources") {
  Page p;
  const std::string html = render_html_report(p.comparison, p.options);
  CHECK(html.rfind("<!DOCTYPE html>", 0) == 0);
  CHECK(count(html, "data-row=\"reference\"") == 1);
  CHECK(count(html, "data-row=\"design\"") == 3);
  CHECK(count(html, "data-status=\"failed\"") == 1);
  CHECK(html.find("failed: t3.json: no target found &lt;/script&gt;") != std::string::npos);
  CHECK(html.find("T&lt;1&gt;") != std::string::npos);
  CHECK(html.find("<td class=\"name\">T<1>") == std::string::npos);
  // Chart.js is inlined from the given file; three canvases for three charts.
  CHECK(html.find("/* stand-in */ window.Chart") != std::string::npos);
  CHECK(count(html, "<canvas") == 3);
  CHECK(html.find("data-charts-expected=\"3\"") != std::string::npos);
  // 75 % of the reference (6 / 8), in the table.
  CHECK(html.find(">75.0&thinsp;%<small>optical 75.0&thinsp;%") != std::string::npos);
  // The Nyquist limit, criterion and versions are on the page.
  CHECK(html.find("Camera sampling (Nyquist) limit") != std::string::npos);
  CHECK(html.find("criterion m(f) &ge; 0.1") != std::string::npos);
  CHECK(html.find("tactres 9.8.7") != std::string::npos);
  CHECK(html.find("tactres 0.1.0") != std::string::npos);
  // The overlay beside a.json is embedded; the others say why not.
  CHECK(count(html, "src=\"data:image/png;base64,") == 1);
  CHECK(html.find("no overlay: b.overlay.png is missing") != std::string::npos);
  CHECK(html.find("no overlay: the measurement failed") != std::string::npos);
  // Self-contained: nothing is loaded from anywhere.
  CHECK_FALSE(std::regex_search(html, std::regex(R"((src|href)\s*=\s*["']?(https?:|//|file:))", std::regex::icase)));
  CHECK(html.find("<link") == std::string::npos);
  // Only the three script elements close a script; markup in the inline
  // data is escaped so that it cannot close one early.
  CHECK(count(html, "</script>") == 3);
  CHECK(html.find("\"design\":\"T\\u003c1>\"") != std::string::npos);
}

TEST_CASE("the HTML page needs Chart.js and says how to install it") {
  Page p;
  p.options.chart_js = p.dir.path / "no-such-chart.js";
  try {
    render_html_report(p.comparison, p.options);
    FAIL("no error without Chart.js");
  } catch (const std::runtime_error& e) {
    const std::string m = e.what();
    CHECK(m.find("no-such-chart.js") != std::string::npos);
    CHECK(m.find("libjs-chart.js") != std::string::npos);
  }
  p.options.thumbnail_max_px = 5;
  CHECK_THROWS_AS(render_html_report(p.comparison, p.options), std::invalid_argument);
}

TEST_CASE("inlined JavaScript cannot end the script element") {
  Page p;
  p.options.chart_js = p.dir.write("evil.js", "var s = '</SCRIPT><b>'; window.Chart = 1;");
  const std::string html = render_html_report(p.comparison, p.options);
  CHECK(html.find("</SCRIPT>") == std::string::npos);
  CHECK(html.find("var s = '<\\/SCRIPT><b>'") != std::string::npos);
}

// /2 inputs: "A" limited by its optics, "L" by light and noise.
struct PageV2 {
  ReportTempDir dir{"reports-html2"};
  Comparison comparison;
  HtmlReportOptions options;
  PageV2() {
    HandMeasurement ref, a, l;
    ref.design = "cmos";
    ref.h.interp = 8.0;
    ref.v.interp = 10.0;
    a.design = "A";
    a.h.interp = a.v.interp = 6.0;
    l.design = "L";
    l.h.interp = 4.0;
    l.v.interp = 5.0;
    testing::limit_by_light(l.h, 7.0, 1.8, l.h_parts);
    testing::limit_by_light(l.v, 9.0, 1.2, l.v_parts);
    for (HandMeasurement* m : {&ref, &a, &l}) m->schema = 2;
    l.cnr[2] = 3.0;  // 4 lp/mm: below k = 5
    auto load = [&](const HandMeasurement& m, const std::string& name) {
      return measurement_from_json(hand_measurement(m), (dir.path / name).string());
    };
    comparison = compare_designs({load(a, "a.json"), load(l, "l.json")}, load(ref, "cmos.json"));
    options.chart_js = dir.write("chart.min.js", "/* stand-in */ window.Chart = function () {};");
  }
};

// The table row of `design` (up to its </tr>).
std::string table_row_of(const std::string& html, const std::string& design) {
  const size_t at = html.find("data-design=\"" + design + "\"");
  REQUIRE(at != std::string::npos);
  return html.substr(at, html.find("</tr>", at) - at);
}

TEST_CASE("the HTML page with measurement/2: limiting factor, the two limits, light needed, CNR(f) charts") {
  PageV2 p;
  const std::string html = render_html_report(p.comparison, p.options);
  // m(f) and CNR(f) per orientation, and the bar chart: five charts.
  CHECK(count(html, "<canvas") == 5);
  CHECK(html.find("data-charts-expected=\"5\"") != std::string::npos);
  CHECK(html.find("id=\"chart-cnr-h\"") != std::string::npos);
  CHECK(html.find("id=\"chart-cnr-v\"") != std::string::npos);
  CHECK(html.find("CNR &ge; k = 5 (red line)") != std::string::npos);
  // The chart script draws the k line from the data, and the CNR values are there.
  CHECK(html.find("Rose threshold k = ") != std::string::npos);
  CHECK(html.find("\"detectability_k\":5.0") != std::string::npos);
  CHECK(html.find("\"c\":3.0,") != std::string::npos);

  const std::string l = table_row_of(html, "L");
  CHECK(count(l, "data-limited-by=\"light/noise\"") == 2);
  // The reported 50 % (4 / 8) tagged with its factor; optics alone would reach 87.5 % (7 / 8).
  CHECK(l.find("<span class=\"tag tag-light\">light/noise</span> 50.0&thinsp;%<small>optical 87.5&thinsp;%<br>"
               "detect. 50.0&thinsp;%</small>") != std::string::npos);
  CHECK(l.find(">×1.8<small>more light</small></td>") != std::string::npos);
  CHECK(l.find("class=\"rank\">2<") != std::string::npos);  // ranked by what it resolves
  const std::string a = table_row_of(html, "A");
  CHECK(count(a, "data-limited-by=\"optics\"") == 2);
  CHECK(a.find("detect. &ge;&thinsp;100.0&thinsp;%") != std::string::npos);  // every element detectable
  CHECK(a.find(">0.25×<small>light to spare</small></td>") != std::string::npos);
  CHECK(a.find("<span class=\"tag tag-optics\">optics</span> 75.0&thinsp;%") != std::string::npos);
  CHECK(a.find("class=\"rank\">1<") != std::string::npos);
  // The card names the light-limited design.
  CHECK(html.find("Limited by light/noise</div><div class=\"val\">L <small>(H, V)</small>") != std::string::npos);
}

TEST_CASE("the HTML page with measurement/1: n/a for detectability, no empty CNR charts") {
  Page p;  // /1 files
  const std::string html = render_html_report(p.comparison, p.options);
  CHECK(count(html, "<canvas") == 3);
  CHECK(html.find("id=\"chart-cnr-") == std::string::npos);
  CHECK(html.find("No CNR(f): these measurements predate the detectability limit") != std::string::npos);
  const std::string b = table_row_of(html, "T2");
  CHECK(count(b, "data-limited-by=\"\"") == 2);
  // No tag, the reported limit as the optical one (4 / 8), and n/a for detectability.
  CHECK(b.find("title=\"reported (the coarser): optical 4.00 lp/mm; detectability not measured (tactres.measurement/1)\">"
               "50.0&thinsp;%<small>optical 50.0&thinsp;%<br>detect. n/a</small>") != std::string::npos);
  CHECK(b.find("class=\"tag") == std::string::npos);
  CHECK(b.find(">n/a</td>") != std::string::npos);  // light needed
  CHECK(html.find("\"detectability_k\":null") != std::string::npos);
}

TEST_CASE("the best-design card names one design, or every design that shares rank 1") {
  Page p;
  std::string html = render_html_report(p.comparison, p.options);
  CHECK(html.find("Best design</div><div class=\"val\">T&lt;1&gt; <small>5.50 lp/mm") != std::string::npos);
  // Two designs the measurements cannot tell apart: the card crowns neither.
  for (DesignRow& r : p.comparison.designs)
    if (r.rank) r.rank = 1;
  html = render_html_report(p.comparison, p.options);
  CHECK(html.find("Best design</div><div class=\"val\">2 tie</div>") != std::string::npos);
  CHECK(html.find("within 2 combined sigma of each other: T&lt;1&gt;, T2") != std::string::npos);
}

}  // namespace
}  // namespace tactres
