#pragma once
// Test support (metrology/locate tests only): one pair of groups of a real
// MIL-STD-150A chart, as measured on three chrome-on-glass charts
// (Miniscope frames of groups 4-7, dev_03/04/05 in ../shared/realdata,
// averaged).

#include "chart_detect_internal.h"

namespace tactres::locate_test {

// For index n modulo 12, the H triplet's centre in units of W (the bar
// width of the pair's even group's element 1), relative to the odd group's
// element 1, chart x right and y down; and the V triplet's offset along x
// (its y is the H triplet's). Negative offsets: V left of H.
struct PairSlot {
  double hx, hy, v_dx;
};
constexpr PairSlot kRealPair[12] = {
    {-1.35, 24.28, -7.17}, {-24.25, 0.73, 6.19}, {-24.48, 7.86, 5.49},  {-24.80, 14.20, 4.95},
    {-25.12, 19.90, 4.44}, {-25.52, 25.21, 4.12}, {0.00, 0.00, -3.55},   {0.06, 4.01, -3.17},
    {0.10, 7.54, -2.80},   {0.18, 10.71, -2.48}, {0.27, 13.55, -2.21},  {0.26, 16.11, -1.95}};
// The next pair (two groups finer) sits a quarter the size at this offset (W).
constexpr Vec2 kInnerPairOffset{-6.93, 9.11};

}  // namespace tactres::locate_test
