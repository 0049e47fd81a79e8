#pragma once
// The comparison as CSV: the reference row, then one row per design in
// order of first appearance. Columns are stable and documented in
// docs/REPORT.md. Absent values are empty cells, never NaN.

#include <string>

#include "tactres/reports/comparison.h"

namespace tactres {

// The header line (with its newline).
std::string report_csv_header();

// The header and every row.
std::string report_csv(const Comparison& c);

}  // namespace tactres
