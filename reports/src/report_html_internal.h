#pragma once
// Pieces of the report page (report_html.cpp) that live in their own
// files: the limits table (report_table.cpp), and the small text helpers
// both use.

#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "tactres/reports/comparison.h"
#include "tactres/reports/html_page.h"

namespace tactres::report_html {

inline std::string esc(std::string_view s) { return html_escape(s); }

inline std::string join(const std::vector<std::string>& parts, std::string_view sep) {
  std::string out;
  for (const std::string& p : parts) {
    if (!out.empty()) out += sep;
    out += p;
  }
  return out;
}

inline std::string num(double v, int digits) { return fmt::format("{:.{}f}", v, digits); }

// <table id="limits">: the reference row, then one row per design.
std::string limits_table(const Comparison& c);

}  // namespace tactres::report_html
