#include "tactres/live/live_csv.h"

#include <fmt/format.h>

#include "tactres/util/csv.h"

namespace tactres {

namespace {

const char* kOrientationColumns =
    "{0}_group,{0}_element,{0}_lp_per_mm,{0}_interpolated_lp_per_mm,{0}_uncertainty_lp_per_mm,{0}_limited_by,"
    "{0}_focus_group,{0}_focus_element,{0}_focus_m,{0}_focus_m_sigma";

std::string orientation_cells(const LiveFrameResult& r, BarOrientation o, const FocusReading& f) {
  if (!r.measured) return ",,,,,,,,,";
  const LimitBreakdown& p = r.measurement.parts(o);
  const Limit& l = p.reported();
  std::string s = l.any_resolved ? fmt::format("{},{},{},", l.group, l.element, csv_number(l.lp_per_mm, 6))
                                 : std::string(",,0,");
  s += csv_number(l.interpolated_lp_per_mm, 6) + "," + csv_number(l.uncertainty_lp_per_mm, 6) + ",";
  s += std::string(to_string(p.limited_by)) + ",";
  if (f.present)
    s += fmt::format("{},{},{},{}", f.group, f.element, csv_number(f.m, 6), csv_number(f.m_sigma, 6));
  else
    s += ",,,";
  return s;
}

// A message on one line: a live CSV is read line by line (tail -f, grep).
std::string one_line(std::string text) {
  for (size_t at; (at = text.find('\n')) != std::string::npos;) text.replace(at, 1, "; ");
  return text;
}

}  // namespace

std::string live_csv_header() {
  return "time_s,frame,name,status,tracked,refit,analysis_ms," +
         fmt::format(fmt::runtime(kOrientationColumns), "h") + "," +
         fmt::format(fmt::runtime(kOrientationColumns), "v") + ",problem\n";
}

std::string live_csv_row(const LiveFrameResult& r, const FocusReading& h, const FocusReading& v) {
  return fmt::format("{},{},{},{},{},{},{},{},{},{}\n", csv_number(r.time_s, 4), r.index, csv_cell(r.name),
                     r.measured ? (r.relative ? "relative" : "ok") : "unusable", r.tracked ? 1 : 0,
                     r.refit ? 1 : 0, csv_number(r.analysis_ms, 3),
                     orientation_cells(r, BarOrientation::horizontal_bars, h),
                     orientation_cells(r, BarOrientation::vertical_bars, v), csv_cell(one_line(r.problem)));
}

}  // namespace tactres
