// The limits table of the report page (docs/REPORT.md, "The HTML page"):
// per orientation the reported limit, its percentage of the raw CMOS limit
// and what limits it, then the mean of H and V and the light needed.

#include "report_html_internal.h"

#include <algorithm>
#include <optional>

namespace tactres::report_html {
namespace {

// "≥ 95.2 %" (a lower bound: every element passed) or "–".
std::string pct_text(std::optional<double> pct, bool lower_bound = false) {
  if (!pct) return "–";
  return fmt::format("{}{:.1f}&thinsp;%", lower_bound ? "&ge;&thinsp;" : "", *pct);
}

// The width of the small bar under a percentage (report.css, .pct).
std::string pct_bar_style(std::optional<double> pct) {
  return pct ? fmt::format(" style=\"--w:{:.1f}%\"", std::clamp(*pct, 0.0, 100.0)) : std::string();
}

std::string pct_cell(std::optional<double> pct) {
  return fmt::format("<td class=\"pct\"{}>{}</td>", pct_bar_style(pct), pct_text(pct));
}

// The reported limit's percentage of raw CMOS with what limits it (a tag),
// and the optical and detectability limits' percentages under it in small
// type: three numbers and a word in one column keep the table readable.
std::string reported_cell(const OrientationSummary& o, const OrientationParts& p, int n) {
  const OrientationSummary& opt = p.optical;
  const std::optional<OrientationSummary>& det = p.detectability;
  auto part = [](const char* name, const OrientationSummary& s) {
    return fmt::format("{} {}{} lp/mm", name, s.beyond_finest ? "≥ " : "",
                       s.value_lp_per_mm() ? num(*s.value_lp_per_mm(), 2) : std::string("none"));
  };
  std::string title = fmt::format("reported (the coarser): {}; {}", part("optical", opt),
                                  det ? part("detectability", *det)
                                      : std::string("detectability not measured (tactres.measurement/1)"));
  if (p.limited_by == LimitedBy::mixed)
    title += fmt::format("; {} of {} presses limited by light/noise", p.light_limited_presses, n);
  // A measurement/1 row gets no tag: "detect. n/a" under it says why.
  const char* cls = p.limited_by == LimitedBy::light_noise ? "light" : p.limited_by == LimitedBy::mixed ? "mixed" : "optics";
  const std::string tag = p.limited_by == LimitedBy::unknown
                              ? std::string()
                              : fmt::format("<span class=\"tag tag-{}\">{}</span> ", cls, to_string(p.limited_by));
  return fmt::format(
      "<td class=\"pct lim\"{} data-limited-by=\"{}\" title=\"{}\">{}{}<small>optical {}<br>detect. {}</small></td>",
      pct_bar_style(o.pct_of_reference), to_string(p.limited_by), esc(title), tag, pct_text(o.pct_of_reference),
      pct_text(opt.pct_of_reference, opt.beyond_finest),
      det ? pct_text(det->pct_of_reference, det->beyond_finest) : std::string("n/a"));
}

std::string light_needed_cell(const DesignRow& r) {
  const std::optional<double> f = r.light_needed_factor;
  const std::string title = fmt::format("exposure factor at which the detectability limit reaches the optical one: "
                                        "horizontal bars {}, vertical bars {}",
                                        light_needed_text(r.horizontal_parts.light_needed_factor),
                                        light_needed_text(r.vertical_parts.light_needed_factor));
  const char* cls = !f ? "" : *f >= 1 ? "light-short" : "light-spare";
  const LightNeededWords words = light_needed_words(f);
  return fmt::format("<td class=\"sep light-needed {}\" title=\"{}\">{}{}</td>", cls, esc(title), esc(words.factor),
                     words.meaning.empty() ? "" : "<small>" + esc(words.meaning) + "</small>");
}

std::string orientation_cells(const OrientationSummary& o, const OrientationParts& parts, int n) {
  std::string s;
  // The element in small type under its lp/mm: one column fewer keeps the
  // table within the page.
  if (o.resolved_any)
    s += fmt::format("<td class=\"sep disc\">{}{}<small>G{}&thinsp;E{}</small></td>", o.beyond_finest ? "&ge;&thinsp;" : "",
                     num(o.lp_per_mm, 2), o.group, o.element);
  else
    s += "<td class=\"sep disc\" title=\"no element resolved: the limit is below the coarsest element\">none"
         "<small>resolved</small></td>";
  if (o.interp_lp_per_mm) {
    std::string title;
    if (n >= 2)
      title = fmt::format("mean of {} presses; sample SD {}; ± combines the SD and the mean uncertainty", n,
                          o.interp_sd_lp_per_mm ? num(*o.interp_sd_lp_per_mm, 3) : "–");
    else
      title = "the measurement's 1-sigma uncertainty";
    s += fmt::format("<td title=\"{}\">{}{}</td>", esc(title), num(*o.interp_lp_per_mm, 2),
                     o.interp_sigma_lp_per_mm
                         ? fmt::format(" <span class=\"pm\">± {}</span>", num(*o.interp_sigma_lp_per_mm, 2))
                         : std::string());
  } else {
    s += "<td title=\"no crossing could be interpolated: the comparison uses the discrete limit\">–</td>";
  }
  s += reported_cell(o, parts, n);
  return s;
}

std::string table_row(const DesignRow& r) {
  const bool ref = r.status == RowStatus::reference;
  const char* role = ref ? "reference" : "design";
  std::string cls = ref ? "reference" : r.status == RowStatus::failed ? "design failed" : "design";
  std::string s = fmt::format("<tr class=\"{}\" data-row=\"{}\" data-design=\"{}\" data-status=\"{}\">", cls, role,
                              esc(r.design), to_string(r.status));
  s += fmt::format("<td class=\"rank\">{}</td>", r.rank ? std::to_string(*r.rank) : "–");
  s += fmt::format("<td class=\"name\">{}</td>", esc(r.design));
  s += fmt::format("<td>{}</td>", r.n_failed ? fmt::format("{}/{}", r.n, r.n + r.n_failed) : std::to_string(r.n));
  if (r.n == 0) {
    std::vector<std::string> problems;
    for (const std::string& p : r.problems) problems.push_back(esc(p));
    s += fmt::format("<td class=\"sep problem\" colspan=\"9\">failed: {}</td>", join(problems, "<br>"));
  } else {
    s += orientation_cells(r.horizontal, r.horizontal_parts, r.n);
    s += orientation_cells(r.vertical, r.vertical_parts, r.n);
    s += fmt::format("<td class=\"sep\">{}</td>", r.mean_hv_lp_per_mm ? num(*r.mean_hv_lp_per_mm, 2) : "–");
    s += pct_cell(r.mean_pct_of_reference);
    s += light_needed_cell(r);
  }
  std::string status = to_string(r.status);
  if (r.status == RowStatus::partly_failed) status = fmt::format("{} of {} failed", r.n_failed, r.n + r.n_failed);
  if (r.status == RowStatus::reference) status = "raw CMOS";
  const std::string title = join(r.problems, "\n");
  s += fmt::format("<td class=\"sep status-{}\"{}>{}</td></tr>\n", to_string(r.status),
                   title.empty() ? "" : fmt::format(" title=\"{}\"", esc(title)), esc(status));
  return s;
}

}  // namespace

std::string limits_table(const Comparison& c) {
  std::string s =
      "<table class=\"limits\" id=\"limits\">\n<thead>\n"
      "<tr><th rowspan=\"2\">Rank</th><th rowspan=\"2\" class=\"name\">Design</th><th rowspan=\"2\" "
      "title=\"usable presses aggregated (of all given)\">n</th>"
      "<th colspan=\"3\" class=\"grp h sep\">Horizontal bars</th><th colspan=\"3\" class=\"grp v sep\">Vertical "
      "bars</th><th colspan=\"2\" class=\"grp sep\">Mean of H and V</th>"
      "<th rowspan=\"2\" class=\"sep\" title=\"exposure factor at which the detectability limit would reach the "
      "optical limit, the larger of H and V\">light<br>needed</th><th rowspan=\"2\" class=\"sep\">Status</th></tr>\n"
      "<tr>";
  for (int k = 0; k < 2; ++k)
    s += "<th class=\"sep\">discrete<br>lp/mm <small>(element)</small></th><th>interpolated<br>lp/mm ± 1σ</th>"
         "<th title=\"the reported limit (the coarser of the optical and the detectability limit) and what limits "
         "it; under it the optical and the detectability limit\">% of raw CMOS<br><small>(limited by)</small></th>";
  s += "<th class=\"sep\">lp/mm</th><th>% of raw<br>CMOS</th></tr>\n</thead>\n<tbody>\n";
  s += table_row(c.reference_row);
  for (const DesignRow& r : c.designs) s += table_row(r);
  s += "</tbody>\n</table>\n";
  return s;
}

}  // namespace tactres::report_html
