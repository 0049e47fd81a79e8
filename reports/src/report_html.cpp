#include "tactres/reports/report_html.h"

#include "reports_assets.h"  // generated from the assets folder at build time

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>
#include <vector>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <OpenImageIO/strutil.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "report_html_internal.h"
#include "tactres/util/atomic_file.h"

namespace tactres {
namespace {

using report_html::esc;
using report_html::join;
using report_html::limits_table;
using report_html::num;

namespace fs = std::filesystem;
using nlohmann::json;

// ---------------------------------------------------------------------------
// The report's own style, after the shared one (html_page.cpp). Print CSS
// keeps the table and each chart on one page.
constexpr const char* kReportCss = kAsset_report_css;  // reports/assets/report.css

// ---------------------------------------------------------------------------
// The report's charts, inside the shared page script (html_page.h: `data`,
// `body`, the rendered-charts counter and textLabels are set up there).
// Small Chart.js plugins: error bars, value labels, failed marks and
// labelled reference lines.
constexpr const char* kReportChartScript = kAsset_report_charts_js;  // reports/assets/report_charts.js

// Thumbnails: a click shows one at full width and back (charts or not).
constexpr const char* kReportAfterScript = kAsset_report_after_js;  // reports/assets/report_after.js

// ---------------------------------------------------------------------------

json opt_json(std::optional<double> v) { return v ? json(*v) : json(); }

json orientation_json(const OrientationSummary& o, const OrientationParts& parts) {
  return {{"value", opt_json(o.value_lp_per_mm())},
          {"interpolated", o.interp_lp_per_mm.has_value()},
          {"sigma", opt_json(o.interp_sigma_lp_per_mm)},
          {"pct", opt_json(o.pct_of_reference)},
          {"limited_by", to_string(parts.limited_by)},
          {"optical_pct", opt_json(parts.optical.pct_of_reference)},
          {"detectability_pct", parts.detectability ? opt_json(parts.detectability->pct_of_reference) : json()}};
}

json curve_points(const MeasurementRecord& m, BarOrientation o) {
  std::vector<const ElementRecord*> ok;
  for (const ElementRecord& e : m.elements)
    if (e.orientation == o && e.status == "ok" && e.m && e.m_sigma) ok.push_back(&e);
  std::sort(ok.begin(), ok.end(), [](const ElementRecord* a, const ElementRecord* b) { return a->lp_per_mm < b->lp_per_mm; });
  json pts = json::array();
  for (const ElementRecord* e : ok)
    pts.push_back({{"f", e->lp_per_mm}, {"m", *e->m}, {"s", *e->m_sigma}, {"g", e->group}, {"e", e->element},
                   {"c", opt_json(e->cnr)}, {"cs", opt_json(e->cnr_sigma)}});
  return pts;
}

json page_data(const Comparison& c) {
  json d;
  d["threshold"] = c.threshold;
  d["detectability_k"] = c.detectability_k > 0 ? json(c.detectability_k) : json();
  d["nyquist"] = {{"h", c.nyquist_h_lp_per_mm}, {"v", c.nyquist_v_lp_per_mm}};
  const DesignRow& ref = c.reference_row;
  d["reference"] = {{"design", ref.design},
                    {"h", orientation_json(ref.horizontal, ref.horizontal_parts)},
                    {"v", orientation_json(ref.vertical, ref.vertical_parts)}};
  d["designs"] = json::array();
  for (const DesignRow& r : c.designs) {
    json row = {{"design", r.design},
                {"status", to_string(r.status)},
                {"rank", r.rank ? json(*r.rank) : json()},
                {"light_needed_factor", opt_json(r.light_needed_factor)}};
    if (r.n > 0) {
      row["h"] = orientation_json(r.horizontal, r.horizontal_parts);
      row["v"] = orientation_json(r.vertical, r.vertical_parts);
    } else {
      row["h"] = row["v"] = nullptr;
    }
    d["designs"].push_back(row);
  }
  d["curves"] = json::array();
  auto add_curve = [&](const MeasurementRecord& m, bool reference, bool first) {
    if (!m.usable) return;
    d["curves"].push_back({{"design", m.design},
                           {"reference", reference},
                           {"first_of_design", first},
                           {"file", m.path.filename().string()},
                           {"h", curve_points(m, BarOrientation::horizontal_bars)},
                           {"v", curve_points(m, BarOrientation::vertical_bars)}});
  };
  add_curve(c.reference, true, true);
  for (const DesignRow& r : c.designs) {
    bool first = true;
    for (size_t i : r.presses) {
      if (!c.measurements[i].usable) continue;
      add_curve(c.measurements[i], false, first);
      first = false;
    }
  }
  return d;
}

// ---------------------------------------------------------------------------

std::string thumbnails(const Comparison& c, int max_px) {
  std::string s = "<div class=\"thumbs\">\n";
  auto figure = [&](const MeasurementRecord& m, bool reference) {
    auto limit = [](const LimitRecord& l) {
      if (!l.resolved_any) return std::string("none");
      return num(l.interpolated_lp_per_mm.value_or(l.lp_per_mm), 2);
    };
    const std::string limits =
        m.usable ? fmt::format(" · H {} · V {} lp/mm", limit(m.horizontal), limit(m.vertical)) : " · failed";
    std::string caption = fmt::format("<b>{}</b>{}{}<span class=\"file\">{}</span>", esc(m.design),
                                      reference ? " (reference)" : "", limits, esc(m.path.filename().string()));
    std::string why;
    std::optional<std::string> uri;
    if (!m.usable)
      why = "no overlay: the measurement failed (" + m.problem + ")";
    else
      uri = thumbnail_data_uri(m.overlay_path(), max_px, &why);
    if (uri)
      s += fmt::format("<figure class=\"thumb\"><img src=\"{}\" alt=\"overlay of {}\"><figcaption>{}</figcaption></figure>\n",
                       *uri, esc(m.design), caption);
    else
      s += fmt::format("<figure class=\"thumb missing\"><div class=\"placeholder\">{}</div><figcaption>{}</figcaption></figure>\n",
                       esc(why), caption);
  };
  figure(c.reference, true);
  for (const DesignRow& r : c.designs)
    for (size_t i : r.presses) figure(c.measurements[i], false);
  return s + "</div>\n";
}

std::string inputs_table(const Comparison& c) {
  std::string s =
      "<table class=\"inputs\"><thead><tr><th>Role</th><th>Design</th><th>Measurement</th><th>Capture</th><th>Result</th>"
      "<th>Preset</th><th>tactres</th></tr></thead><tbody>\n";
  auto row = [&](const MeasurementRecord& m, const char* role) {
    s += fmt::format("<tr><td>{}</td><td>{}</td><td class=\"file\">{}</td><td class=\"file\">{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
                     role, esc(m.design), esc(m.path.string()), esc(m.image),
                     m.usable ? "usable" : "<span class=\"status-failed\">failed</span>: " + esc(m.problem),
                     esc(m.preset.empty() ? "–" : m.preset), esc(m.tactres_version.empty() ? "–" : m.tactres_version));
  };
  row(c.reference, "reference");
  for (const DesignRow& r : c.designs)
    for (size_t i : r.presses) row(c.measurements[i], "design");
  return s + "</tbody></table>\n";
}

std::string lp(std::optional<double> v, std::optional<double> sigma = std::nullopt) {
  if (!v) return "–";
  std::string s = num(*v, 2);
  if (sigma) s += fmt::format(" <small>± {}</small>", num(*sigma, 2));
  return s;
}

// Which designs light and noise hold back, at a glance.
std::string light_card(const Comparison& c) {
  std::vector<std::string> light;
  bool known = std::any_of(c.designs.begin(), c.designs.end(), [](const DesignRow& r) { return r.n > 0; });
  for (const DesignRow& r : c.designs) {
    if (r.n == 0) continue;
    const OrientationParts* parts[2] = {&r.horizontal_parts, &r.vertical_parts};
    std::vector<std::string> where;
    for (int k = 0; k < 2; ++k) {
      if (parts[k]->limited_by == LimitedBy::unknown) known = false;
      if (parts[k]->limited_by == LimitedBy::light_noise || parts[k]->limited_by == LimitedBy::mixed)
        where.push_back(k == 0 ? "H" : "V");
    }
    if (!where.empty()) light.push_back(fmt::format("{} <small>({})</small>", esc(r.design), join(where, ", ")));
  }
  std::string val = !light.empty() ? join(light, ", ") : known ? "none" : "n/a";
  std::string detail = !light.empty() ? "the detectability limit is the coarser: more light would help"
                       : known        ? "every design is limited by its optics"
                                      : "no usable design, or measurements from before the detectability limit";
  return fmt::format(
      "<div class=\"card light-card\"><div class=\"k\">Limited by light/noise</div><div class=\"val\">{}</div>"
      "<div class=\"detail\">{}{}</div></div>\n",
      val, detail, c.detectability_k > 0 ? fmt::format("; Rose k = {}", c.detectability_k) : "");
}

std::string cards(const Comparison& c) {
  const DesignRow& ref = c.reference_row;
  std::string s = "<section class=\"cards\">\n";
  s += fmt::format(
      "<div class=\"card\"><div class=\"k\">Raw CMOS limit ({})</div><div class=\"val\">H {} <small>lp/mm</small>"
      "</div><div class=\"val\">V {} <small>lp/mm</small></div><div class=\"detail\">the bare camera; {}</div></div>\n",
      esc(ref.design), lp(ref.horizontal.value_lp_per_mm(), ref.horizontal.interp_sigma_lp_per_mm),
      lp(ref.vertical.value_lp_per_mm(), ref.vertical.interp_sigma_lp_per_mm),
      ref.horizontal.interp_lp_per_mm && ref.vertical.interp_lp_per_mm ? "interpolated, ± 1σ"
                                                                        : "discrete where no interpolation");
  const bool nyq = c.nyquist_h_lp_per_mm > 0 && c.nyquist_v_lp_per_mm > 0;
  s += fmt::format(
      "<div class=\"card\"><div class=\"k\">Camera sampling (Nyquist) limit</div><div class=\"val\">{}</div>"
      "<div class=\"detail\">at the target plane, from the reference measurement</div></div>\n",
      nyq ? fmt::format("H {} <small>lp/mm</small></div><div class=\"val\">V {} <small>lp/mm</small>",
                        num(c.nyquist_h_lp_per_mm, 2),
                        num(c.nyquist_v_lp_per_mm, 2))
          : std::string("not available"));
  // Rank 1 may be shared (designs within 2 combined sigma of each other):
  // the card then names them all, so it never crowns one the data cannot.
  std::vector<const DesignRow*> first;
  int failed = 0;
  for (const DesignRow& r : c.designs) {
    if (r.rank && *r.rank == 1) first.push_back(&r);
    if (r.status == RowStatus::failed) ++failed;
  }
  if (first.size() == 1) {
    const DesignRow* best = first.front();
    s += fmt::format(
        "<div class=\"card\"><div class=\"k\">Best design</div><div class=\"val\">{} <small>{} lp/mm</small></div>"
        "<div class=\"detail\">mean of H and V{}</div></div>\n",
        esc(best->design), num(*best->mean_hv_lp_per_mm, 2),
        best->mean_pct_of_reference ? fmt::format(", {:.1f} % of raw CMOS", *best->mean_pct_of_reference) : "");
  } else if (first.size() > 1) {
    std::vector<std::string> names;
    for (const DesignRow* r : first) names.push_back(esc(r->design));
    s += fmt::format(
        "<div class=\"card\"><div class=\"k\">Best design</div><div class=\"val\">{} tie</div>"
        "<div class=\"detail\">at rank 1, within 2 combined sigma of each other: {}</div></div>\n",
        first.size(), fmt::join(names, ", "));
  } else
    s += "<div class=\"card\"><div class=\"k\">Best design</div><div class=\"val\">none ranked</div></div>\n";
  s += light_card(c);
  s += fmt::format(
      "<div class=\"card\"><div class=\"k\">Designs</div><div class=\"val\">{} <small>compared</small></div>"
      "<div class=\"detail\">{} measurements{}</div></div>\n",
      c.designs.size(), c.measurements.size() + 1, failed ? fmt::format("; {} design(s) failed", failed) : "");
  return s + "</section>\n";
}

bool has_cnr(const Comparison& c) {
  auto any = [](const MeasurementRecord& m) {
    return m.usable && std::any_of(m.elements.begin(), m.elements.end(), [](const ElementRecord& e) { return e.cnr.has_value(); });
  };
  return any(c.reference) || std::any_of(c.measurements.begin(), c.measurements.end(), any);
}

// m(f) and, when the measurements have it (/2), CNR(f) beside it: one row
// per orientation, so that what the optics transfer and what stands out of
// the noise read side by side. /1 measurements get no empty CNR charts.
std::string curves_section(const Comparison& c) {
  const bool cnr = has_cnr(c);
  auto chart = [](const char* id, const std::string& heading, const std::string& label) {
    return fmt::format(
        "<div><h3>{}</h3><div class=\"chart-box\"><canvas id=\"{}\" role=\"img\" aria-label=\"{}\"></canvas>"
        "</div></div>\n",
        heading, id, label);
  };
  std::string s = fmt::format("<section id=\"curves\">\n<h2>{}</h2>\n<div class=\"curves{}\">\n",
                              cnr ? "Modulation m(f) and contrast-to-noise CNR(f) versus spatial frequency"
                                  : "Modulation m(f) versus spatial frequency",
                              cnr ? " with-cnr" : "");
  for (const auto& [key, name] : {std::pair{"h", "Horizontal bars"}, std::pair{"v", "Vertical bars"}}) {
    const std::string lower = key == std::string("h") ? "horizontal bars" : "vertical bars";
    s += chart(key == std::string("h") ? "chart-mtf-h" : "chart-mtf-v", cnr ? std::string(name) + ": m(f)" : name,
               "m(f) of " + lower);
    if (cnr)
      s += chart(key == std::string("h") ? "chart-cnr-h" : "chart-cnr-v", std::string(name) + ": CNR(f)",
                 "CNR(f) of " + lower);
  }
  s += "</div>\n";
  s += fmt::format(
      "<p class=\"note\">Each press's elements with status ok: m ± 1σ as measured. An element is resolved when m "
      "&ge; {} (red line) and m &minus; {}σ &gt; 0 (on a chart photograph its gaps' model-free dips may show the "
      "latter instead). Repeated presses of a design share its colour; the raw CMOS "
      "curve is black and dashed.",
      c.threshold, c.significance_z);
  if (cnr)
    s += fmt::format(
        " CNR(f): each bar's contrast-to-noise ratio in one frame (Rose), ± 1σ, on a log scale; an element is "
        "detectable when CNR &ge; {} (red line) and significantly above 0. More light moves these curves up, "
        "never the m(f) ones.",
        c.detectability_k > 0 ? fmt::format("k = {}", c.detectability_k) : std::string("k"));
  else
    s += " No CNR(f): these measurements predate the detectability limit (tactres.measurement/1).";
  return s + "</p>\n</section>\n";
}

}  // namespace

void HtmlReportOptions::validate() const {
  if (thumbnail_max_px < 32 || thumbnail_max_px > 4096)
    throw std::invalid_argument(fmt::format(
        "thumbnail size {} px is out of range: use 32 to 4096 px (the long side of each overlay thumbnail)",
        thumbnail_max_px));
  if (chart_js.empty()) throw std::invalid_argument("the Chart.js path is empty");
}

std::string base64_encode(std::string_view bytes) { return OIIO::Strutil::base64_encode(bytes); }

std::optional<std::string> thumbnail_data_uri(const fs::path& path, int max_px, std::string* why_not) {
  auto no = [&](const std::string& why) {
    if (why_not) *why_not = why;
    return std::nullopt;
  };
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return no("no overlay: " + path.filename().string() + " is missing");
  auto in = OIIO::ImageInput::open(path.string());
  if (!in) {
    (void)OIIO::geterror();  // clear OIIO's per-thread error
    return no("no overlay: " + path.filename().string() + " cannot be decoded");
  }
  const OIIO::ImageSpec spec = in->spec();
  const int w = spec.width, h = spec.height, nc = spec.nchannels;
  if (w <= 0 || h <= 0 || nc <= 0) return no("no overlay: " + path.filename().string() + " is empty");
  constexpr std::uintmax_t kMaxEmbeddedBytes = 400 * 1024;
  const bool small = std::max(w, h) <= max_px;
  if (small && std::string(in->format_name()) == "png" && fs::file_size(path, ec) <= kMaxEmbeddedBytes && !ec)
    return "data:image/png;base64," + base64_encode(read_file(path));

  std::vector<unsigned char> pixels(size_t(w) * size_t(h) * size_t(nc));
  if (!in->read_image(0, 0, 0, nc, OIIO::TypeDesc::UINT8, pixels.data())) {
    (void)in->geterror();
    return no("no overlay: " + path.filename().string() + " cannot be decoded");
  }
  in->close();
  // To 3-channel RGB: grey is replicated, alpha dropped.
  cv::Mat rgb(h, w, CV_8UC3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const unsigned char* p = &pixels[(size_t(y) * w + x) * nc];
      cv::Vec3b& q = rgb.at<cv::Vec3b>(y, x);
      q = nc >= 3 ? cv::Vec3b(p[0], p[1], p[2]) : cv::Vec3b(p[0], p[0], p[0]);
    }
  if (!small) {
    const double scale = double(max_px) / std::max(w, h);
    cv::Mat out;
    cv::resize(rgb, out, cv::Size(std::max(1, int(std::lround(w * scale))), std::max(1, int(std::lround(h * scale)))),
               0, 0, cv::INTER_AREA);
    rgb = out;
  }
  std::vector<unsigned char> jpeg;
  OIIO::Filesystem::IOVecOutput proxy(jpeg);
  auto writer = OIIO::ImageOutput::create("thumbnail.jpg");
  if (!writer) return no("no overlay: JPEG encoding is not available");
  OIIO::ImageSpec out_spec(rgb.cols, rgb.rows, 3, OIIO::TypeDesc::UINT8);
  out_spec.attribute("Compression", "jpeg:88");
  writer->set_ioproxy(&proxy);
  if (!writer->open("thumbnail.jpg", out_spec) ||
      !writer->write_image(OIIO::TypeDesc::UINT8, rgb.data, 3, int(rgb.step)) || !writer->close()) {
    (void)writer->geterror();
    return no("no overlay: the thumbnail of " + path.filename().string() + " could not be encoded");
  }
  return "data:image/jpeg;base64," +
         base64_encode(std::string_view(reinterpret_cast<const char*>(jpeg.data()), jpeg.size()));
}

std::string render_html_report(const Comparison& c, const HtmlReportOptions& options) {
  options.validate();
  // Read first: a missing Chart.js fails before any thumbnail is encoded.
  const std::string chart_js = read_chart_js(options.chart_js, "the HTML report", "give its path with --chart-js");

  std::set<std::string> versions;
  for (const MeasurementRecord& m : c.measurements)
    if (!m.tactres_version.empty()) versions.insert(m.tactres_version);
  if (!c.reference.tactres_version.empty()) versions.insert(c.reference.tactres_version);
  const std::string measured_with = join(std::vector<std::string>(versions.begin(), versions.end()), ", ");

  // The kind of page (style, data id, charts) first; then this one's content.
  HtmlPage page{.css = kReportCss,
                .data_id = "report-data",
                .chart_script = kReportChartScript,
                .after_script = kReportAfterScript};
  page.title = fmt::format("Design comparison: {} design{} vs raw CMOS ({})", c.designs.size(),
                           c.designs.size() == 1 ? "" : "s", c.reference_row.design);
  page.heading = "Design comparison: resolution limits in lp/mm";
  page.subtitle_html = fmt::format(
      "{} design{} against the bare camera <b>{}</b> (raw CMOS) · criterion m(f) &ge; {} and m &minus; {}σ &gt; 0 · "
      "layout <code>{}</code> · report by tactres {}",
      c.designs.size(), c.designs.size() == 1 ? "" : "s", esc(c.reference_row.design), c.threshold, c.significance_z,
      esc(c.layout), esc(options.tactres_version));
  page.tactres_version = options.tactres_version;
  page.data = page_data(c);

  std::string& s = page.body_html;
  s.reserve(200000);
  s += cards(c);

  s += "<section id=\"table\">\n<h2>Limits per design</h2>\n" + limits_table(c);
  s += "<ul class=\"note\">\n"
       "<li><b>discrete</b> (element): the finest element resolved together with every coarser one (for "
       "repeated presses, the coarsest over the presses); &ge; means every element was resolved, a lower "
       "bound.</li>\n"
       "<li><b>interpolated</b>: where m(f) crosses the criterion between elements. One press: its value ± its "
       "1σ uncertainty. Repeated presses (n &gt; 1): the mean ± the press-to-press sample SD and the mean "
       "uncertainty in quadrature (hover for the SD).</li>\n"
       "<li><b>% of raw CMOS</b>: the interpolated limit (the discrete one where there is none) as a percentage "
       "of the reference's. <b>Mean of H and V</b> ranks the designs; failed designs are shown, never "
       "ranked.</li>\n"
       "<li>The limits above are the <b>reported</b> ones: the coarser of the <b>optical</b> limit (where m(f) "
       "falls below the criterion; light cannot move it) and the <b>detectability</b> limit (where the bars sink "
       "into one frame's pixel noise, CNR below the Rose threshold k; light moves it). The tag before the "
       "percentage names the coarser (<i>optics</i> or <i>light/noise</i>; <i>mixed</i> when repeated presses "
       "disagree), and both limits follow under it as % of the raw CMOS limit (&ge;: every element passed, a lower "
       "bound; hover for lp/mm). <i>detect. n/a</i>, no tag: a measurement from before the detectability limit "
       "(tactres.measurement/1), whose reported limit is its optical one.</li>\n"
       "<li><b>Light needed</b>: the exposure factor at which the detectability limit would reach the optical one "
       "(the larger of H and V; over repeated presses the largest). ×1.8 more light: light and noise hold the "
       "design back; 0.4×: the design would still reach its optical limit with 40 % of its light.</li>\n";
  for (const std::string& n : c.notes) s += "<li>" + esc(n) + "</li>\n";
  for (const DesignRow& r : c.designs)
    for (const std::string& p : r.problems)
      s += fmt::format("<li class=\"status-failed\">{} — failed press {}</li>\n", esc(r.design), esc(p));
  s += "</ul>\n</section>\n";

  s += "<section id=\"bars\">\n<h2>Horizontal and vertical limits per design</h2>\n"
       "<div class=\"chart-box\"><canvas id=\"chart-bars\" role=\"img\" aria-label=\"grouped bar chart of the "
       "limits per design\"></canvas></div>\n"
       "<p class=\"note\">Bars: the limit (interpolated where available) with 1σ error bars and the percentage of "
       "the raw CMOS limit above each bar. Dashed lines: the bare camera's limits; dotted: the camera's sampling "
       "(Nyquist) limit at the target plane.</p>\n</section>\n";

  s += curves_section(c);

  s += "<section id=\"overlays\">\n<h2>Overlays</h2>\n<p class=\"note\" style=\"margin-top:0\">Each capture with "
       "the sampled strips coloured by status (green resolved, orange not resolved, red graded, purple below the "
       "sampling limit; the limit element of each orientation in a white line; a key under each image). "
       "Click to enlarge.</p>\n";
  s += thumbnails(c, options.thumbnail_max_px);
  s += "</section>\n";

  s += "<section id=\"inputs\">\n<h2>Inputs</h2>\n" + inputs_table(c) + "</section>\n";
  s += fmt::format(
      "<footer>\n<p>Generated by tactres {} from measurements made with tactres {}. This report only aggregates "
      "the measurements (means, spreads, percentages, ranks); every limit, uncertainty and m(f) is as "
      "<code>tactres measure</code> wrote it.</p>\n<p>Charts: Chart.js (MIT licence), inlined; the page needs no "
      "network.</p>\n</footer>\n",
      esc(options.tactres_version), esc(measured_with.empty() ? "an unknown version" : measured_with));
  return render_html_page(page, chart_js);
}

}  // namespace tactres
