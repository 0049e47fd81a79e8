// The group numbers printed above the columns of a chart whose arrangement
// was recognised (chart_detect.h, "Anchor"): read where the arrangement
// says they stand, turned upright by its orientation, by OCR in any
// typeface. The phase fixes the largest element's index modulo 12, so each
// number read chooses among k = phase + 12 j.

#include <cmath>
#include <map>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "chart_detect_internal.h"

namespace tactres::locate_detail {

cv::Mat upright_patch(const cv::Mat& img, const ChartDetection::Arrangement& A, Vec2 center_px, int width,
                      int height) {
  const Vec2 down = A.down_px;
  const Vec2 x_dir = (A.mirrored ? -1.0 : 1.0) * Vec2{down.y, -down.x};
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

}  // namespace

std::optional<int> index_from_column_labels(LabelReader& reader, const ChartDetection& D,
                                            const std::vector<ChartElement>& kept, const cv::Mat& img, int phase,
                                            std::string& note) {
  const Ink ink = D.light_bars ? Ink::light : Ink::dark;
  const Vec2 down = D.arrangement.down_px;
  std::map<int, int> votes;  // j -> readings that fit k = phase + 12 j
  int read = 0, unfit = 0;
  for (const ChartElement& e : kept) {
    const int n12 = mod12(e.relative_index + phase);
    if (n12 != 1 && n12 != 6) continue;
    const double W = 0.5 * e.period_px * std::exp2(n12 / 6.0);
    const Vec2 mid = 0.5 * (D.patterns[e.h].center_px + D.patterns[e.v].center_px);
    // The band must lie in the image (a replicated border reads as
    // anything): near the frame's edge its far side is pulled in, down to
    // kAboveMinToW.
    std::optional<Vec2> center;
    int width = static_cast<int>(std::lround(2 * kHalfWidthW * W)), height = 0;
    for (double to_w = kAboveToW; to_w >= kAboveMinToW && !center; to_w -= 0.5) {
      const Vec2 c = mid - (0.5 * (kAboveFromW + to_w) * W) * down;
      height = static_cast<int>(std::lround((to_w - kAboveFromW) * W));
      if (inside(img, c, width, height, down)) center = c;
    }
    if (!center || 0.4 * height < kMinLabelCharPx) continue;
    const std::optional<NumberReading> r =
        reader.read_number(upright_patch(img, D.arrangement, *center, width, height), ink);
    if (!r || r->box_px.height < kMinLabelCharPx) continue;
    ++read;
    bool fits = false;
    for (int j = -4; j <= 4; ++j)
      if (floor_div6(e.relative_index + phase + 12 * j) == r->value) ++votes[j], fits = true;
    unfit += !fits;
  }
  int best_j = 0, best = 0, others = unfit;
  for (const auto& [j, n] : votes)
    if (n > best) others += best, best = n, best_j = j;
    else others += n;
  if (best == 0 || (others > 0 && (best < 2 || best < 2 * others))) {
    note = read == 0 ? "no group number read above the columns"
                     : fmt::format("{} group number(s) read above the columns, but they do not agree on the group", read);
    return std::nullopt;
  }
  const int k = phase + 12 * best_j, g = floor_div6(k);
  note = fmt::format("{} of {} group number(s) read above the columns fit the largest element found being group {} "
                     "element {}",
                     best, read, g, k - 6 * g + 1);
  return k;
}

}  // namespace tactres::locate_detail
