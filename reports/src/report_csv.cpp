#include "tactres/reports/report_csv.h"

#include <cmath>

#include <fmt/format.h>

#include "tactres/util/csv.h"

namespace tactres {
namespace {

// group,element,lp_per_mm,beyond_finest,interp,interp_sd,interp_sigma,pct
std::string orientation_cells(const OrientationSummary& o, bool measured) {
  if (!measured) return ",,,,,,,";
  const bool r = o.resolved_any;
  return fmt::format("{},{},{},{},{},{},{},{}", r ? std::to_string(o.group) : "", r ? std::to_string(o.element) : "",
                     r ? csv_number(o.lp_per_mm, 4) : "", r ? (o.beyond_finest ? "true" : "false") : "",
                     csv_number(o.interp_lp_per_mm, 4), csv_number(o.interp_sd_lp_per_mm, 4), csv_number(o.interp_sigma_lp_per_mm, 4),
                     csv_number(o.pct_of_reference, 2));
}

// An exposure factor spans decades (a bright design needs 1e-4 of its
// light), so it keeps 4 significant digits rather than fixed decimals.
std::string csv_factor(std::optional<double> factor) {
  return factor && std::isfinite(*factor) ? fmt::format("{:.4g}", *factor) : std::string();
}

// One part (optical or detectability): value,sigma,beyond_finest,pct. The
// value is the one compared (interpolated, else discrete), as for the
// reported limit.
std::string part_cells(const std::optional<OrientationSummary>& o) {
  if (!o) return ",,,";
  return fmt::format("{},{},{},{}", csv_number(o->value_lp_per_mm(), 4), csv_number(o->interp_sigma_lp_per_mm, 4),
                     o->resolved_any ? (o->beyond_finest ? "true" : "false") : "",
                     csv_number(o->pct_of_reference, 2));
}

// limited_by, the optical part, the detectability part, light_needed_factor.
std::string parts_cells(const OrientationParts& p, bool measured) {
  if (!measured) return ",,,,,,,,,";
  return fmt::format("{},{},{},{}", to_string(p.limited_by), part_cells(p.optical), part_cells(p.detectability),
                     csv_factor(p.light_needed_factor));
}

std::string row_csv(const Comparison& c, const DesignRow& row) {
  const bool is_ref = row.status == RowStatus::reference;
  const bool measured = row.n > 0;
  std::string files;
  if (is_ref) {
    files = c.reference.path.string();
  } else {
    for (size_t i : row.presses) {
      if (!files.empty()) files += ';';  // piecewise: GCC 12 warns falsely on "..." + string
      files += c.measurements[i].path.string();
    }
  }
  std::string problems;
  for (const std::string& p : row.problems) {
    if (!problems.empty()) problems += " | ";
    problems += p;
  }
  // Sigma basis: which uncertainty interp_sigma is (docs/REPORT.md).
  const char* basis = row.n == 1 ? "measurement" : row.n >= 2 ? "spread_and_mean_sigma" : "";
  // The two-limit columns come last, so that readers of the older columns
  // find them where they were.
  return fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n", is_ref ? "reference" : "design",
                     csv_cell(row.design), row.n, row.n_failed, to_string(row.status),
                     orientation_cells(row.horizontal, measured), orientation_cells(row.vertical, measured), basis,
                     csv_number(row.mean_hv_lp_per_mm, 4), csv_number(row.mean_pct_of_reference, 2),
                     row.rank ? std::to_string(*row.rank) : "",
                     is_ref && c.nyquist_h_lp_per_mm > 0 ? csv_number(c.nyquist_h_lp_per_mm, 4) : "",
                     is_ref && c.nyquist_v_lp_per_mm > 0 ? csv_number(c.nyquist_v_lp_per_mm, 4) : "",
                     fmt::format("{}", c.threshold), csv_cell(problems), csv_cell(files),
                     parts_cells(row.horizontal_parts, measured), parts_cells(row.vertical_parts, measured),
                     csv_factor(row.light_needed_factor),
                     c.detectability_k > 0 ? fmt::format("{}", c.detectability_k) : "");
}

}  // namespace

std::string report_csv_header() {
  std::string h = "role,design,n,n_failed,status";
  for (const char* o : {"h", "v"})
    h += fmt::format(
        ",{0}_group,{0}_element,{0}_lp_per_mm,{0}_beyond_finest,{0}_interp_lp_per_mm,{0}_interp_sd_lp_per_mm,"
        "{0}_interp_sigma_lp_per_mm,{0}_pct_of_reference",
        o);
  h += ",sigma_basis,mean_hv_lp_per_mm,mean_pct_of_reference,rank,nyquist_h_lp_per_mm,nyquist_v_lp_per_mm,"
       "threshold,problem,files";
  for (const char* o : {"h", "v"}) {
    h += fmt::format(",{}_limited_by", o);
    for (const char* part : {"optical", "detectability"})
      h += fmt::format(",{0}_{1}_lp_per_mm,{0}_{1}_sigma_lp_per_mm,{0}_{1}_beyond_finest,{0}_{1}_pct_of_reference", o,
                       part);
    h += fmt::format(",{}_light_needed_factor", o);
  }
  h += ",light_needed_factor,detectability_k\n";
  return h;
}

std::string report_csv(const Comparison& c) {
  std::string out = report_csv_header() + row_csv(c, c.reference_row);
  for (const DesignRow& row : c.designs) out += row_csv(c, row);
  return out;
}

}  // namespace tactres
