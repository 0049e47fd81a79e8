#pragma once
// `tactres watch --csv FILE`: one row per frame, written as it goes
// (docs/LIVE.md, "CSV"). Absent values are empty cells, never NaN.

#include <string>

#include "tactres/live/focus_history.h"
#include "tactres/live/live_measure.h"

namespace tactres {

std::string live_csv_header();

// The row of one frame; `h` and `v` are the focus element's readings.
std::string live_csv_row(const LiveFrameResult& r, const FocusReading& h, const FocusReading& v);

}  // namespace tactres
