#pragma once
// Finding a standard USAF-1951 chart (MIL-STD-150A) in a photograph with no
// fiducials and no layout file (`tactres measure --chart usaf1951`).
//
// 1. Bars: the image is binarised against its local mean at a ladder of
//    window sizes (so bars of any size stand out against their own
//    surroundings), in both polarities (dark bars: positive chart; light
//    bars: negative chart). Connected components whose second moments are
//    those of a filled 5:1 rectangle are bar candidates. Digits (whose
//    seven segments touch, so each digit is one blob), the large square and
//    dust are not 5:1 rectangles and drop out here.
// 2. Patterns: three parallel bars of the same size, one period (2 bar
//    widths) apart and side by side, make a three-bar pattern: its centre,
//    bar direction and period in pixels.
// 3. Elements: two perpendicular patterns of the same period, 2.5..5
//    periods apart, make an element. The one whose bars are parallel to the
//    line joining the two is the horizontal-bar pattern (in the chart frame
//    the H triplet sits beside the V triplet along x); this holds under any
//    rotation and mirroring.
// 4. Indices: elements are numbered from the largest found, one step per
//    2^(1/6) in period; a fine element whose position in the nested pairs
//    (each pair of groups the pair two coarser at 1/4) says its blurred
//    period misled it is moved by one.
// 5. Anchor: the absolute group comes from --px-per-mm (the largest
//    element's frequency follows from its period), or from --largest-group
//    (the largest element found is element --largest-element of it), or,
//    without either, from the arrangement (see below), or else from the
//    printed group and element numbers read by OCR in any typeface
//    (labels/label_reader.h; src/chart_labels.cpp).
//    When none of them fixes the group, indices stay relative and the
//    result says so, and why.
//
// What the arrangement can and cannot tell (docs/CHART.md, "Anchor"):
// - The topology of the elements found fixes the index modulo 12, that is
//   each element's number (1..6) and its group's parity, and the
//   handedness: odd groups run 1..6 down the right column, even groups
//   2..6 down the left with element 1 at the lower right, and on charts as
//   made the H triplet stands left of the V triplet only in the even
//   group's column (left everywhere on the generated chart). Which found
//   elements stand one below the other, and on which side each H triplet
//   stands, is scored against every phase, handedness and style; the
//   makers' spacings differ, so distances only decide what is a column step.
// - They cannot fix the group beyond its parity: pairs are nested 4 times
//   smaller (2 groups), so pair (g, g+1) looks exactly like pair (g+2, g+3)
//   at another distance. Only the printed numbers do: the generated chart's
//   seven-segment group numbers are fitted as templates; any other
//   typeface is read by OCR (chart_labels.cpp), upright by the orientation
//   the arrangement found, the group numbers choosing among the indices
//   the phase allows.
//
// Mild perspective is absorbed because every pattern has its own frame.

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "tactres/targets/geometry.h"

namespace tactres {

struct ChartDetectOptions {
  std::optional<int> largest_group;      // --largest-group G (-10..12)
  int largest_element = 1;               // with largest_group: which element the largest one is, 1..6
  std::optional<double> px_per_mm;       // --px-per-mm N at the chart plane, (0, 1e5]
  double min_bar_px = 1.2;               // finer bars are not searched for
  void validate() const;                 // throws std::invalid_argument
};

// One three-bar pattern in the image.
struct BarPattern {
  Vec2 center_px;
  Vec2 bar_dir;             // unit vector along the bars' long side
  double period_px = 0;     // bar + gap, across the bars
  double bar_length_px = 0;
  bool light_bars = false;  // bars brighter than the ground (negative chart)
  std::array<Vec2, 3> bar_centers_px{};
  bool predicted = false;   // not found but placed by its column or the nesting (see ChartDetection)
  bool nested = false;      // predicted by the nesting: a coarser pair's pattern scaled by 1/4
};

enum class ChartAnchor { none, largest_group, px_per_mm, arrangement, printed_numbers };
const char* to_string(ChartAnchor a);

// One element: a horizontal- and a vertical-bar pattern of the same size.
struct ChartElement {
  int h = -1, v = -1;       // indices into ChartDetection::patterns; -1: not found (partial elements and
                            // a single-pattern detection only)
  double period_px = 0;     // mean of the two
  int relative_index = 0;   // 0 = the largest element found; +1 per 2^(1/6) finer
  int group = 0, element = 1;  // absolute when anchored; else relative (largest = group 0 element 1)
  // Only one of the two patterns was found (the other index is -1). The
  // found pattern is measured; the missing one is reported with a graded
  // status, never measured or resolved: `out_of_view` when it lies outside
  // the image (the element is partly out of view), `fit_failed` when it
  // lies inside but was not found there. `partial_reason` says which, in
  // words. (With the arrangement recognised, a missing pattern inside the
  // image is placed and measured instead: ChartDetection::partners_placed.)
  enum class Partial { no, partner_out_of_view, partner_not_found } partial = Partial::no;
  std::string partial_reason;
  // Its two patterns were found apart: one lone pattern indexed it, and the
  // other, also lone, stands where the arrangement puts the partner, but
  // with a period beyond the pairing's tolerance (a field's distortion).
  // Both are measured; like a placed partner, neither confirms the index.
  bool partner_joined = false;
};

struct ChartDetection {
  bool found = false;
  std::string problem;              // why not found, and what to do
  std::vector<BarPattern> patterns;
  std::vector<ChartElement> elements;  // coarse to fine
  bool light_bars = false;          // negative chart
  ChartAnchor anchor = ChartAnchor::none;
  std::string anchor_description;   // what the anchor was, in words
  // When --largest-group or --px-per-mm fixed the anchor and the chart's
  // own arrangement and printed numbers fix another: both, in words (a
  // warning; the option stands). Empty otherwise.
  std::string anchor_conflict;
  int largest_index = 0;            // absolute series index 6 g + e - 1 of relative index 0
  int unpaired_patterns = 0;        // patterns the pairing left without a partner (measured only in
                                    // `partial`, or in an element joined by place: partner_joined)
  double separation_periods = 3.5;  // an element's H-to-V centre distance in its periods (the chart's median)
  // The H triplets' period over the V triplets' (the ratio the patterns
  // were paired at): 1 seen face on; a chart seen obliquely is
  // foreshortened across the tilt's axis (about 1 / cos(tilt) when the axis
  // is the chart's y).
  double hv_period_ratio = 1;
  // The row pitch of a coherent fibre bundle's honeycomb over the image,
  // px (0: none). The chart is then found, and its numbers read, on a copy
  // smoothed at the lattice's scale; it is measured on the image itself,
  // where bars narrower than the pitch are beyond the bundle's sampling.
  double fibre_lattice_pitch_px = 0;
  // Elements placed, not found (their patterns are `predicted`):
  // - the element after the finest one found in a column, where three found
  //   elements in a row fix the column's geometric progression (each element
  //   2^(-1/6) the size of the one before, and so its offset); never past
  //   element 6 of a numbered group;
  // - the elements of a nested pair of groups: each pair is the pair two
  //   groups coarser scaled by 1/4 about one point, fitted from the elements
  //   found 12 indices apart (chart_detect_internal.h, fit_nesting); only
  //   into a pair that shows an element found, and only numbered (anchored
  //   or the arrangement recognised).
  // Bars too faint to binarise are still measured there, so that the limit
  // can be bracketed.
  int predicted_elements = 0;
  // Elements of which one pattern was found and the other placed beside
  // it (predicted): with the arrangement recognised, the side and the
  // distance (separation_periods) are known, so a pattern in view that was
  // not found is measured where it stands; the found one keeps its place.
  int partners_placed = 0;
  // Elements of which only one pattern was found (ChartElement::partial):
  // lone, well-sampled patterns whose period falls on the series at an
  // index that no element holds. Kept apart from `elements` (which all have
  // both patterns): the found pattern is measured, the missing one graded.
  std::vector<ChartElement> partial;
  // One three-bar pattern and nothing else of a chart: a microscope frame
  // that holds a single triplet of one element (its partner and the digits
  // out of view). It is measured as elements[0], whose other index is -1.
  // Nothing in the frame tells which of the element's two triplets it is,
  // so its orientation is the image's (bars along image x: horizontal_bars).
  // Only a pattern with bars >= kSinglePatternMinBarPx wide that is the
  // only one of its size counts: small triplets turn up in texture.
  bool single_pattern = false;
  static constexpr double kSinglePatternMinBarPx = 8;
  // The standard arrangement, when recognised (see the top of this file):
  // the index of relative index 0 modulo 12 and the handedness; the group
  // labels read from the image, if any.
  struct Arrangement {
    bool recognised = false;
    int phase = 0;              // absolute index of relative index 0, modulo 12
    bool mirrored = false;      // seen from behind (or through a relay)
    bool generated_style = false;  // every H triplet left of its V triplet, as `tactres generate --chart` draws them
    Vec2 down_px{0, 1};         // the chart's +y (down its columns) in the image, unit
    int steps_checked = 0;      // element-to-element steps compared with the arrangement
    int steps_matched = 0;
    int labels_read = 0;        // group labels read (0: the group is known modulo 2 only)
    std::string note;           // what was or was not recognised, in words
    // Not recognised because it fits in several ways about equally: each
    // way's phase (empty otherwise).
    std::vector<int> candidate_phases;
  } arrangement;
};

// Whether one of element e's patterns was found and the other placed
// beside it (ChartDetection::partners_placed).
inline bool partner_placed(const ChartDetection& D, const ChartElement& e) {
  return e.h >= 0 && e.v >= 0 && D.patterns[e.h].predicted != D.patterns[e.v].predicted;
}

// Whether element e's index rests on one of its patterns alone: its
// partner placed (partner_placed) or joined (ChartElement::partner_joined).
inline bool index_from_one_pattern(const ChartDetection& D, const ChartElement& e) {
  return e.partner_joined || partner_placed(D, e);
}

// Whether at least one of element e's patterns was found in the image (not
// both predicted: ChartDetection::predicted_elements).
inline bool found_in_image(const ChartDetection& D, const ChartElement& e) {
  return (e.h >= 0 && !D.patterns[e.h].predicted) || (e.v >= 0 && !D.patterns[e.v].predicted);
}

// The largest element found: the one the indices count from (relative
// index 0, which --largest-group names). A partner placed beside a found
// pattern (ChartDetection::partners_placed) can be coarser. Null when the
// chart was not found.
inline const ChartElement* largest_found(const ChartDetection& D) {
  for (const ChartElement& e : D.elements)
    if (e.relative_index == 0) return &e;
  return nullptr;
}

ChartDetection detect_chart(const cv::Mat& luminance, const ChartDetectOptions& options);

}  // namespace tactres
