#pragma once
// Seven-segment label glyphs ('0'-'9', '-', '.') built from non-overlapping
// rectangles, shared by every target layout (the project's packed layout and
// the MIL-STD-150A chart). Labels are artwork only; no measurement reads them.

#include <vector>

#include "tactres/targets/geometry.h"

namespace tactres {

// Appends the rectangles of glyph `c` in a box of width `w`, height `h` and
// stroke `t` whose top-left corner is `origin` (mm). Unknown characters add
// nothing. Adjacent segments touch, so a digit is one connected shape.
void append_glyph(char c, Vec2 origin, double w, double h, double t, std::vector<RectMm>& out);

}  // namespace tactres
