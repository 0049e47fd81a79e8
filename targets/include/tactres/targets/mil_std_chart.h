#pragma once
// The standard USAF-1951 resolution chart (MIL-STD-150A arrangement) as a
// TargetLayout, so that every existing emitter (SVG, raster, height map, STL,
// layout JSON) and the simulator handle it unchanged.
//
// Arrangement, per pair of groups (g even, g + 1), in units of W, the bar
// width of element g.1 (a pair is 4 times smaller than the one around it):
//   - group g elements 2..6 in a column down the left side;
//   - group g + 1 elements 1..6 in a column down the right side, from the
//     upper right;
//   - group g element 1 at the lower right, under that column;
//   - the group numbers above the two columns;
//   - the next pair nested in the space between the columns ("spiralling
//     inward"); the outermost pair also holds the large square, at the
//     lower middle, which is the reference patch (level step).
// Every element is its element digit, then the horizontal-bar triplet, then
// the vertical-bar triplet, each 2 bar widths apart; elements in a column
// are 2.5 bar widths apart. There are no fiducials: a standard chart has
// none (see metrology chart_detect.h for how it is found).
//
// A first group that is odd leaves the even half of the first pair empty;
// a last group that is even leaves the odd half of the last pair empty.

#include "tactres/targets/layout.h"

namespace tactres {

struct MilStdChartOptions {
  int first_group = -2;             // coarsest group, -10..12
  int last_group = 7;               // finest group, >= first_group
  double relief_height_mm = 0.1;    // (0, 10]
  double base_thickness_mm = 2.0;   // (0, 100]
  Polarity polarity = Polarity::dark_bars_on_light;

  // Throws std::invalid_argument naming the bad option and its valid range.
  void validate() const;
};

// Geometry of one element in bar widths (w), from the element block's
// top-left corner: digit [0, kDigitWidth] x [0.5, 4.5], H triplet at
// x in [kHX, kHX + 5], V triplet at x in [kVX, kVX + 5], y in [0, 5].
namespace mil_std {
inline constexpr double kDigitWidth = 2.4;
inline constexpr double kDigitHeight = 4.0;
inline constexpr double kDigitStroke = 0.8;
inline constexpr double kTripletGap = 2.0;  // digit -> H triplet -> V triplet
inline constexpr double kHX = kDigitWidth + kTripletGap;
inline constexpr double kVX = kHX + 5.0 + kTripletGap;
inline constexpr double kBlockWidth = kVX + 5.0;
inline constexpr double kColumnGap = 2.5;   // between elements in a column
inline constexpr double kSquareSide = 5.0;  // the large square, in W
}  // namespace mil_std

// The chart's size is the outermost pair plus a margin of 2 W; its origin is
// the top-left corner.
TargetLayout make_mil_std_chart(const MilStdChartOptions& options);

}  // namespace tactres
