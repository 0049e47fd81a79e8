// The group numbers printed above the columns (and above an even group's
// element 1) of a chart whose arrangement was recognised (chart_detect.h,
// "Anchor"): read where the arrangement says they stand, turned upright by
// its orientation, by OCR in any typeface. The phase fixes the largest
// element's index modulo 12, so each number read chooses among
// k = phase + 12 j.

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <vector>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "chart_detect_internal.h"

namespace tactres::locate_detail {

cv::Mat upright_patch(const cv::Mat& img, const ChartDetection::Arrangement& A, Vec2 center_px, int width,
                      int height) {
  const Vec2 down = A.down_px;
  const Vec2 x_dir = chart_x_px(A);
  const Vec2 o = center_px - (0.5 * width) * x_dir - (0.5 * height) * down;
  // Upright patch pixel (u, v) <- image o + u x_dir + v down.
  const cv::Matx23d patch_to_image(x_dir.x, down.x, o.x, x_dir.y, down.y, o.y);
  cv::Mat patch;
  cv::warpAffine(img, patch, patch_to_image, {width, height}, cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                 cv::BORDER_REPLICATE);
  return patch;
}

namespace {

// Where a group number stands, in units of W (the bar width of the pair's
// even group's element 1), above the middle of the element heading its
// column (an even group's element 2, an odd group's element 1): measured on
// three makers' charts (dev_04, dev_14 and the generated one) between 3.4
// and 5.7 W above, 1.8 to 3.7 W tall. The band clears the element's own
// top (2.2 W above its middle at most).
constexpr double kAboveFromW = 2.6, kAboveToW = 8.0, kAboveMinToW = 6.0, kHalfWidthW = 3.5;
// Real charts print an even group's number a second time, above its
// element 1's H triplet towards the right end (dev_03: the "4" and "6"
// centred 3.4-3.6 W right of the triplet's middle and 4.0-4.2 W above it,
// 2.6-3.0 W tall; there the frame cuts the column tops). In units of that
// element's own bar width; the band narrows, down to the digit's own width,
// where the frame is near.
constexpr double kE1RightW = 3.5, kE1FromW = 2.6, kE1ToW = 6.0, kE1HalfWidthW = 2.5, kE1MinHalfWidthW = 1.3;

// Whether a width x height patch centred at c, turned by `down`, lies in
// the image.
bool inside(const cv::Mat& img, Vec2 c, int width, int height, Vec2 down) {
  const Vec2 x{down.y, -down.x};
  for (double sx : {-0.5, 0.5})
    for (double sy : {-0.5, 0.5}) {
      const Vec2 q = c + (sx * width) * x + (sy * height) * down;
      if (q.x < 0 || q.y < 0 || q.x > img.cols - 1 || q.y > img.rows - 1) return false;
    }
  return true;
}

// A place where a group number may stand: an upright patch, and the
// relative index of an element of that group.
struct Site {
  Vec2 center_px;
  int width = 0, height = 0;
  int relative_index = 0;
};

// Above the element heading its column. The band must lie in the image (a
// replicated border reads as anything): near the frame's edge its far side
// is pulled in, down to kAboveMinToW.
std::optional<Site> column_site(const ChartDetection& D, const ChartElement& e, int n12, const cv::Mat& img) {
  const Vec2 down = D.arrangement.down_px;
  const double W = 0.5 * e.period_px * std::exp2(n12 / 6.0);
  const Vec2 mid = 0.5 * (D.patterns[e.h].center_px + D.patterns[e.v].center_px);
  const int width = static_cast<int>(std::lround(2 * kHalfWidthW * W));
  for (double to_w = kAboveToW; to_w >= kAboveMinToW; to_w -= 0.5) {
    const Vec2 c = mid - (0.5 * (kAboveFromW + to_w) * W) * down;
    const int height = static_cast<int>(std::lround((to_w - kAboveFromW) * W));
    if (inside(img, c, width, height, down)) return Site{c, width, height, e.relative_index};
  }
  return std::nullopt;
}

// Where the middle of pattern p's bars would be had the frame not cut
// them: bars shorter than 2.5 periods whose end lies within half a period
// of the image's edge were cut there, so the middle lies that way by half
// the missing length (a frame cutting G4E1's V triplet moved its centre
// 0.5 bar widths, enough to clip the number above its H triplet).
Vec2 uncut_center(const BarPattern& p, const cv::Mat& img) {
  const double missing_px = 2.5 * p.period_px - p.bar_length_px;
  if (missing_px <= 0) return p.center_px;
  const auto to_edge = [&](Vec2 q) { return std::min({q.x, q.y, img.cols - 1 - q.x, img.rows - 1 - q.y}); };
  for (const double sign : {1.0, -1.0}) {
    const Vec2 end = p.center_px + (sign * 0.5 * p.bar_length_px) * p.bar_dir;
    if (to_edge(end) < 0.5 * p.period_px) return p.center_px + (sign * 0.5 * missing_px) * p.bar_dir;
  }
  return p.center_px;
}

// Above an even group's element 1's H triplet, found or (for a partial
// element whose V triplet alone was found) D.separation_periods along the
// chart's x from its V triplet, on the side the maker's style puts it
// (h_side).
std::optional<Site> element_one_site(const ChartDetection& D, const ChartElement& e, int phase, const cv::Mat& img) {
  const ChartDetection::Arrangement& A = D.arrangement;
  const Vec2 x_dir = chart_x_px(A);
  if (e.h < 0 && e.v < 0) return std::nullopt;
  const double h_left = h_side(e.relative_index + phase, A.generated_style);
  const Vec2 h_center = e.h >= 0 ? D.patterns[e.h].center_px
                                 : uncut_center(D.patterns[e.v], img) -
                                       (h_left * D.separation_periods * e.period_px) * x_dir;
  const double w = 0.5 * e.period_px;
  const Vec2 c = h_center + (kE1RightW * w) * x_dir - (0.5 * (kE1FromW + kE1ToW) * w) * A.down_px;
  const int height = static_cast<int>(std::lround((kE1ToW - kE1FromW) * w));
  // Narrower, then also moved along x by up to a bar width: the digit
  // (about 2.4 w wide) stays in the band.
  for (int tenths = 0; kE1HalfWidthW - 0.1 * tenths >= kE1MinHalfWidthW - 1e-9; ++tenths) {
    const int width = static_cast<int>(std::lround(2 * (kE1HalfWidthW - 0.1 * tenths) * w));
    for (double shift_w : {0.0, -0.25, 0.25, -0.5, 0.5, -0.75, 0.75, -1.0, 1.0}) {
      const Vec2 moved = c + (shift_w * w) * x_dir;
      if (inside(img, moved, width, height, A.down_px)) return Site{moved, width, height, e.relative_index};
    }
  }
  return std::nullopt;
}

// How far the band must move along each of its axes (px; 0: not) to
// centre ink that one of its edges cuts: ink touching both edges of an
// axis fills the band that way, and moving would not help.
Vec2 shift_to_uncut(const cv::Rect& box, int width, int height) {
  const auto along = [](int lo, int extent, int size) {
    const bool at_lo = lo <= 0, at_hi = lo + extent >= size;
    return at_lo != at_hi ? lo + 0.5 * extent - 0.5 * size : 0.0;
  };
  return {along(box.x, box.width, width), along(box.y, box.height, height)};
}

// The number at `site`. A digit cut by one edge of the band is no evidence
// (a "7" cut at its foot reads as a confident 2 or 3: dev_01, whose group
// numbers stand nearer their columns than on the charts the band was
// measured on), and often reads as nothing (dev_03 turned 180 deg: its "4"
// above G4E1, 0.3 bar widths off the band's middle, lost the top of its
// arms): the band is moved to centre the ink and read again, up to
// kMaxMoves times (each move shows more of the digit, so centres it
// better), and a digit still cut is not read. Ink that reads as nothing is
// followed only where it fills two thirds of the band along the cut axis
// (a band that grazes a digit, as one placed by a wrong way of the
// arrangement does, is not moved onto it), and its reading counts only if
// the whole glyph is at most 1.5 times what first showed (two thirds of
// it were in view: a 5 cut below its bowl reads as a 3).
constexpr int kMaxMoves = 3;
std::optional<NumberReading> read_site(LabelReader& reader, const cv::Mat& img, const ChartDetection::Arrangement& A,
                                       const Site& site, Ink ink, Counters counters) {
  Vec2 center = site.center_px;
  int width = site.width;
  std::optional<cv::Size> first_unread;  // the ink's extent when first followed unread
  for (int move = 0;; ++move) {
    const cv::Mat patch = upright_patch(img, A, center, width, site.height);
    const std::optional<NumberReading> r = reader.read_number(patch, ink, counters);
    const std::optional<cv::Rect> glyphs = r ? std::optional<cv::Rect>(r->box_px) : reader.glyph_box(patch, ink, counters);
    if (!glyphs) return std::nullopt;
    const Vec2 shift = shift_to_uncut(*glyphs, width, site.height);
    if (shift.x == 0 && shift.y == 0) {
      const bool grew = first_unread && (glyphs->width > 1.5 * first_unread->width ||
                                         glyphs->height > 1.5 * first_unread->height);
      return grew ? std::nullopt : r;
    }
    // A glyph cut at one edge is moved by half the band's unfilled extent.
    if (!r && (std::abs(shift.x) > 0.25 * glyphs->width || std::abs(shift.y) > 0.25 * glyphs->height))
      return std::nullopt;
    if (!r && !first_unread) first_unread = glyphs->size();
    center = center + shift.x * chart_x_px(A) + shift.y * A.down_px;
    // Near the frame a band moved along the column narrows (the tilt of
    // dev_03 mirrored put a corner of its "4"'s band past the edge), never
    // onto the ink's own columns.
    if (shift.x == 0) {
      const double ink_half_px = std::max(std::abs(glyphs->x - 0.5 * width),
                                          std::abs(glyphs->x + glyphs->width - 0.5 * width)) + 2;
      while (!inside(img, center, width, site.height, A.down_px) && width - 2 >= 2 * ink_half_px) width -= 2;
    }
    if (move == kMaxMoves || !inside(img, center, width, site.height, A.down_px)) return std::nullopt;
  }
}

}  // namespace

std::optional<int> index_from_placed_group_numbers(LabelReader& reader, const ChartDetection& D,
                                                   const std::vector<ChartElement>& kept,
                                                   const std::vector<ChartElement>& partial, const cv::Mat& img,
                                                   int phase, std::string& note, int min_readings) {
  const Ink ink = D.light_bars ? Ink::light : Ink::dark;
  // Under a fibre bundle the numbers are read smoothed (chart_labels.cpp),
  // where a blurred numeral's counters fill in at Otsu's threshold.
  const Counters counters = D.fibre_lattice_pitch_px > 0 ? Counters::reopen : Counters::keep;
  std::vector<Site> sites;
  for (const std::vector<ChartElement>* list : {&kept, &partial})
    for (const ChartElement& e : *list) {
      const int n12 = mod12(e.relative_index + phase);
      const bool complete = e.h >= 0 && e.v >= 0;
      std::optional<Site> site;
      if (complete && (n12 == 1 || n12 == 6)) site = column_site(D, e, n12, img);
      if (n12 == 0) site = element_one_site(D, e, phase, img);
      if (site && 0.4 * site->height >= kMinLabelCharPx) sites.push_back(*site);
    }
  std::map<int, int> votes;  // j -> readings that fit k = phase + 12 j
  int read = 0, unfit = 0;
  for (const Site& site : sites) {
    const std::optional<NumberReading> r = read_site(reader, img, D.arrangement, site, ink, counters);
    if (!r || r->box_px.height < kMinLabelCharPx) continue;
    ++read;
    bool fits = false;
    for (int j = -4; j <= 4; ++j)
      if (floor_div6(site.relative_index + phase + 12 * j) == r->value) ++votes[j], fits = true;
    unfit += !fits;
  }
  int best_j = 0, best = 0, others = unfit;
  for (const auto& [j, n] : votes)
    if (n > best) others += best, best = n, best_j = j;
    else others += n;
  if (best == 0 || best < min_readings || (others > 0 && (best < 2 || best < 2 * others))) {
    note = read == 0 ? "no group number read where the arrangement puts them (above a column, or by an even "
                       "group's element 1)"
           : best > 0 && best < min_readings && others == 0
               ? fmt::format("{} group number(s) read where the arrangement puts them, fewer than the {} needed here",
                             best, min_readings)
               : fmt::format("{} group number(s) read where the arrangement puts them, but they do not agree on the "
                             "group",
                             read);
    return std::nullopt;
  }
  const int k = phase + 12 * best_j, g = floor_div6(k);
  note = fmt::format("{} of {} group number(s) read where the arrangement puts them (above a column, or by an even "
                     "group's element 1) agree: the largest element found is group {} element {}",
                     best, read, g, k - 6 * g + 1);
  return k;
}

}  // namespace tactres::locate_detail
