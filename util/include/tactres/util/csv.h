#pragma once
// CSV cells as RFC 4180 writes them: every tactres CSV (measurements,
// reports, bench) goes through these, so a comma or a quote in a file name
// or a message never breaks a row.

#include <optional>
#include <string>

namespace tactres {

// The text as one cell: quoted (with inner quotes doubled) only when it
// holds a comma, a quote or a line break.
std::string csv_cell(const std::string& text);

// A number with `digits` decimals, or an empty cell when there is none or
// it is not finite (CSV has no NaN).
std::string csv_number(std::optional<double> value, int digits);

}  // namespace tactres
