#include "tactres/util/json_fields.h"
#include "tactres/reports/html_page.h"

#include "reports_assets.h"  // generated from the assets folder at build time

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
constexpr const char* kBaseCss = kAsset_page_css;  // reports/assets/page.css

// The page script around the page's own chart code. Chart.js's defaults
// match the page's type; animation is off so that a chart is final when it
// first renders, which is when the counter plugin counts it (the browser
// tests wait for data-charts-rendered to reach data-charts-expected).
constexpr const char* kScriptBeforeCharts = kAsset_page_before_charts_js;  // reports/assets/page_before_charts.js

constexpr const char* kScriptAfterCharts = kAsset_page_after_charts_js;  // reports/assets/page_after_charts.js

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
  const std::string s = json_text(j, -1);
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
