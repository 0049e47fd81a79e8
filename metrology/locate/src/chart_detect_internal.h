#pragma once
// Private to locate: the stages of detect_chart (chart_detect.h).
//   chart_bars.cpp         steps 1-3: bars (components by runs), three-bar
//                          patterns, elements
//   chart_arrangement.cpp  the standard arrangement: its steps between
//                          elements, the column ends, the nesting
//   chart_segment_labels.cpp  the generated chart's seven-segment group labels
//   chart_labels.cpp, chart_group_labels.cpp  printed numbers by OCR
//   chart_detect.cpp       the rest: indices, anchor, partial elements

#include <algorithm>
#include <cmath>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "tactres/labels/label_reader.h"
#include "tactres/locate/chart_detect.h"
#include "tactres/targets/geometry.h"

namespace tactres::locate_detail {

inline Vec2 perp(Vec2 d) { return {-d.y, d.x}; }

// A pixel position `octaves` levels down a cv::pyrDown pyramid, seen at full
// resolution (negative: a full-resolution position seen that far down).
// pyrDown centres small pixel x on full pixel 2x (a line at x = 20 lands at
// 10.00), so positions scale about the origin, not about pixel centres.
inline Vec2 from_octave(Vec2 p, int octaves) { return std::exp2(octaves) * p; }

// floor(n / d) for any sign of n (d > 0).
inline int floor_div(int n, int d) { return n >= 0 ? n / d : -((-n + d - 1) / d); }

// floor(n / 6): the group of series index n = 6 g + e - 1.
inline int floor_div6(int n) { return floor_div(n, 6); }

// n modulo 12 in 0..11 for any sign of n: a series index's place in its
// pair of groups.
inline int mod12(int n) { return ((n % 12) + 12) % 12; }

// ---------------------------------------------------------------------------
// Bars and patterns (chart_bars.cpp).

// The three-bar patterns of each polarity in `img` (finite pixels): dark
// bars (a positive chart) and light ones (a negative chart), bars at least
// min_bar_px wide.
struct PatternsFound {
  std::vector<BarPattern> dark, light;
};
// Which image the bars are looked for in:
// - linear: the luminance as loaded;
// - stabilised: its square root, where photon noise (whose variance grows
//   with the level) is about the same at every level, so that one noise
//   margin fits a chart lit unevenly.
// Both are searched over a Gaussian pyramid (the window ladder beyond 15 px
// is taken an octave down per doubling), where texture finer than a bar (a
// fibre bundle's honeycomb, laser speckle) is gone while wider bars remain.
// In linear light the bright speckle of dev_11's lit side set the margin
// and its dim bars in the shadow were lost (9 elements found in the full
// frame, 36 in the square root); in the square root, read noise in the
// dark grows instead. detect_chart keeps the one that shows more elements.
// Only where the bars are is decided here; they are measured in linear
// light.
enum class ImageScale { linear, stabilised };
// `contrast_sigmas` > 0: a bar's margin is also at least that many robust
// sigmas of the local contrast (the mottle a smoothed texture leaves).
PatternsFound find_patterns(const cv::Mat& img, double min_bar_px, ImageScale scale, double contrast_sigmas = 0);

// The row pitch (px) of a coherent fibre bundle's hexagonal core lattice
// over the image (dev_01: 4.61, dev_02: 6.87), from the power spectrum of
// the image's centred 256 px square: a ring of power well above the radii
// beside it, with three peaks 60 degrees apart on it (fibre_lattice.cpp);
// nullopt when there is none with a pitch of 3-10 px (a lattice with rows
// 10-20 px apart gives none, not a harmonic's pitch), or the image is
// smaller than the square (every real capture not taken through a bundle).
std::optional<double> fibre_lattice_pitch_px(const cv::Mat& img);
// Under such a lattice the chart is found on a copy smoothed with Gaussian
// sigma kLatticeSmoothingPitches x its pitch (the lattice keeps 6 % of its
// amplitude, bars one pitch wide half theirs), its bars held against
// kLatticeMottleSigmas robust sigmas of the local contrast left.
constexpr double kLatticeSmoothingPitches = 0.38, kLatticeMottleSigmas = 4;

// One horizontal run of marked pixels of a mask: x0..x1 inclusive, row y.
struct MaskRun {
  int x0, x1, y;
};
// The 8-connected components of a CV_8U mask (nonzero = marked) as runs:
// `runs` receives every run in raster order, and the result holds, per
// run, the index of its component's first run (the same partition as
// cv::connectedComponents with connectivity 8). Work is per run, not per
// pixel: unmarked stretches are skipped 8 bytes at a time.
std::vector<int> run_components(const cv::Mat& mask, std::vector<MaskRun>& runs);

// A CV_32F image less its means over k x k windows, k odd, for each k of
// `windows` (at least one), into `contrast` (CV_32F, the image's size):
// BORDER_REFLECT at the edges of the image, or of the image it is a region
// of, as cv::blur. One integral image a band of rows serves every window.
void local_contrast(const cv::Mat& img, const std::vector<int>& windows, std::vector<cv::Mat>& contrast);

// Elements: perpendicular patterns of the same period side by side, each
// pattern in one element at most (the best-fitting pairs first).
struct Pairing {
  std::vector<ChartElement> elements;
  int unpaired = 0;
  std::vector<int> lone;  // the unpaired patterns
  double ln_hv_ratio = 0;  // ln of the H/V period ratio paired at (ChartDetection::hv_period_ratio)
};
Pairing pair_patterns(const std::vector<BarPattern>& P);
// ChartDetection::problem when the patterns P (of one polarity) make no
// element: what is in view, and what to do.
std::string no_element_problem(const std::vector<BarPattern>& P);

// ---------------------------------------------------------------------------
// The image scale over the chart (chart_detect.cpp): perspective makes it
// vary, ln(scale) = g . position with `position` the image point relative
// to the image's centre in half image sizes; level0 is ln of the bar width
// (px) at relative index 0 and the image's centre.
struct ScaleField {
  Vec2 g{0, 0};
  int cols = 0, rows = 0;  // the image's size, px
  double half = 1;         // half the image's larger side, px
  double level0 = 0;

  Vec2 position(Vec2 px) const { return Vec2{(px.x - 0.5 * cols) / half, (px.y - 0.5 * rows) / half}; }
  // An element's position: the middle of its two patterns.
  Vec2 position(const ChartDetection& D, const ChartElement& e) const;
  // An element's bar width from the series and the field (the binarised
  // period of a blurred fine pattern is too large).
  double bar_px(const ChartDetection& D, const ChartElement& e) const;
};

// ---------------------------------------------------------------------------
// The standard arrangement (chart_arrangement.cpp, chart_detect.h).

// Phase and handedness of D.elements into D.arrangement (see chart_detect.h).
// When the elements found fit the arrangement in two to
// kMaxArrangementWays ways about equally well (within 3 observations of
// the best, which refuses it; too little of the chart in view: a column
// and one more element fit as an even group's element 1 and its column,
// and mirrored as an even group's element 6 and the odd group's column),
// D.arrangement stays unrecognised and `ways` receives each of them,
// recognised, for the printed numbers to choose from; otherwise `ways` is
// left empty.
constexpr size_t kMaxArrangementWays = 4;
void recognise_arrangement(ChartDetection& D, const ScaleField& field,
                           std::vector<ChartDetection::Arrangement>* ways = nullptr);

// The group number printed above the column that starts with element `e`
// (n_mod12: its index modulo 12, 1 or 6), of the parity of parity_group, or
// nullopt when no reading is clearly best. bar_px: e's bar width.
std::optional<int> read_group_label(const cv::Mat& img, const ChartDetection& D, const ChartElement& e,
                                    int n_mod12, int parity_group, double bar_px);

// A pattern's binarised period is trusted to index it from this size up
// (px); a finer one's may be a step off under blur.
constexpr double kWellSampledPeriodPx = 8;

// No element is placed (predicted) with bars narrower than this: far below
// sampling there is nothing to model or measure.
constexpr double kMinPredictedBarPx = 0.8;

// The series index (6 g + e - 1) of relative index 0: absolute when
// anchored; right modulo 12 (each element's number and its group's parity)
// when only the arrangement is recognised; nullopt when neither.
inline std::optional<int> series_origin(const ChartDetection& D) {
  if (D.anchor != ChartAnchor::none) return D.largest_index;
  if (D.arrangement.recognised) return D.arrangement.phase;
  return std::nullopt;
}

// Elements in the order of their relative index (coarse to fine).
inline void sort_by_index(std::vector<ChartElement>& E) {
  std::sort(E.begin(), E.end(),
            [](const ChartElement& a, const ChartElement& b) { return a.relative_index < b.relative_index; });
}

// The arrangement nests: each pair of groups is the pair two groups
// coarser (12 indices) scaled by 1/4 about one point of the chart, on the
// makers' charts and the generated one alike. fit_nesting finds that point
// from the elements found 12 indices apart (kept: complete elements,
// relative indices from 0, coarse to fine; partial: lone patterns indexed
// by the series, partial_elements, which detect_chart offers only where
// the complete elements do not nest by themselves), and moves a complete fine element's
// index by one where its position says its period misled (blur), keeping
// the indices unique. Nullopt when fewer than four patterns nest about one
// point, one complete element among them (two elements are four patterns
// that must each land within a quarter period, and never less than 2.5
// px: dev_05's inner pair shows only G6E2 and G6E3; resized by 0.8 it
// shows G6E2 whole and only one triplet each of G6E1 and G6E4, and G6E2's
// period, 4 % short, indexed it G6E3).
// The point is sought from each element alone and from each two together;
// among as many patterns that nest, fewer index moves win, then the
// closer fit.
std::optional<Vec2> fit_nesting(const ChartDetection& D, std::vector<ChartElement>& kept,
                                const std::vector<ChartElement>& partial = {});

// See ChartDetection::predicted_elements: the ends of the columns found,
// then the elements of the pairs nested inside the ones held, about
// centre_px (cols x rows: the image, which they must lie in).
void predict_column_ends(ChartDetection& D);
void predict_nested_pairs(ChartDetection& D, Vec2 centre_px, int cols, int rows);

// One image the printed numbers are read in, with what reading it finds
// alike under every way of the arrangement: its label boxes, and the boxes
// read upright as a way turns them (ways that differ only in the phase
// turn them alike; a deque, so that a turn read stays where it is).
struct NumberSite {
  cv::Mat img;
  std::optional<std::vector<cv::Rect>> boxes;
  struct Upright {
    Vec2 down_px;
    bool mirrored = false;
    std::vector<std::vector<NumberReading>> read;  // per box (empty: no reading, or not read yet)
    std::vector<bool> done;                        // per box: read
  };
  std::deque<Upright> upright;
};

// The images the printed numbers are read in, made once per detection and
// shared by every way of the arrangement: the image a pyramid level down
// where the numbers are large, and its copy without fine texture. Before,
// each way searched both images for label boxes again: 170 ms a search on
// dev_02's 1.3 Mpx frame (before labels_detail::local_darkest), 1.0 s of
// its 1.5 s detection over its three ways.
struct NumberImages {
  const uchar* source_data = nullptr;  // the image they were made from; null until made
  int levels = 0;     // octaves down the pyramid
  double bar_px = 0;  // the finest element's bar width there
  NumberSite small, cleaned;  // cleaned.img: without_fine_texture(small.img), once needed
  NumberSite check;           // under a fibre bundle: small smoothed more, which must read alike
  NumberSite cleaned_check;   // without_fine_texture(check.img), once needed
};

// The anchor from the printed group and element numbers, read by OCR
// (chart_labels.cpp): sets D.largest_index and returns true when the
// numbers read fix it; `note` says what was read, or why not. `phase`:
// D.largest_index modulo 12 when the arrangement fixed it. Numbers are
// also read beside the `partial` elements (ChartElement::partial).
// `images` keeps what the reading finds alike from call to call
// within one detection: every call with it must pass the same `img`,
// `kept` and `partial` (and D's patterns and polarity), only D's
// arrangement and `phase` may differ.
bool anchor_by_printed_numbers(ChartDetection& D, const std::vector<ChartElement>& kept,
                               const std::vector<ChartElement>& partial, const cv::Mat& img,
                               std::optional<int> phase, std::string& note, NumberImages& images);

// Partial elements (ChartElement::partial; chart_partial.cpp): each lone
// pattern (indices into D.patterns) with >= 4 px per period whose period
// falls on the series at an index no element of D.elements holds, its
// missing partner placed beside it on the nearest complete element's side.
std::vector<ChartElement> partial_elements(const ChartDetection& D, const std::vector<int>& lone,
                                           const ScaleField& field, const cv::Mat& img);
// Numbers them by the anchor into D.partial, those an element (found or
// predicted) holds the index of dropped. With the arrangement recognised
// the partner's side is the maker's, and a partner in view is placed and
// its element joins D.elements (ChartDetection::partners_placed). A lone
// pattern (of `lone`) found where a missing partner stands completes its
// element instead (ChartElement::partner_joined).
void number_partial_elements(ChartDetection& D, std::vector<ChartElement> partial, const std::vector<int>& lone,
                             int cols, int rows);

// The image without texture finer than a printed stroke (a fibre bundle's
// honeycomb), for reading the numbers when they cannot be read in the
// image itself: dark and light detail narrower than a disc of radius
// bar_px / 3 (bar_px: the finest element's bar width, px; radius 1 to 4 px)
// is removed, wider strokes and the ground keep their levels.
cv::Mat without_fine_texture(const cv::Mat& img, double bar_px);

// Printed numbers shorter than this (px) are not evidence: Tesseract reads
// a blurred 7 x 11 px blob as a confident "4" (dev_04).
constexpr double kMinLabelCharPx = 12;

// Which side of its V triplet the H triplet of the element of index n (any
// relative index plus the arrangement's phase) stands on: on MIL-STD-150A
// charts as made (Thorlabs, Edmund, printed copies) the H triplet is left
// of the V triplet in the even group's column and right of it elsewhere
// (the odd group's column and the even group's element 1); on the chart
// tactres generates it is left everywhere. +1: left (chart_arrangement.cpp).
int h_side(int n, bool generated_style);

// The chart's +x (along its rows, un-mirrored) in the image, unit.
inline Vec2 chart_x_px(const ChartDetection::Arrangement& A) {
  return (A.mirrored ? -1.0 : 1.0) * Vec2{A.down_px.y, -A.down_px.x};
}

// The image around `center_px` turned upright and un-mirrored by the
// arrangement's orientation (A.down_px, A.mirrored): a width x height patch
// whose x runs along the chart's x and y down its columns
// (chart_group_labels.cpp).
cv::Mat upright_patch(const cv::Mat& img, const ChartDetection::Arrangement& A, Vec2 center_px, int width,
                      int height);

// With the arrangement recognised (phase: the largest element's index
// modulo 12), the group numbers printed above the columns and above an
// even group's element 1 (also a partial one, whose H triplet may be cut),
// read upright where the arrangement puts them: the largest element's
// absolute index when they agree on one, read at least min_readings
// times, else nullopt; `note` says what was read (chart_group_labels.cpp).
std::optional<int> index_from_placed_group_numbers(LabelReader& reader, const ChartDetection& D,
                                                   const std::vector<ChartElement>& kept,
                                                   const std::vector<ChartElement>& partial, const cv::Mat& img,
                                                   int phase, std::string& note, int min_readings = 1);

}  // namespace tactres::locate_detail
