#include "tactres/labels/label_boxes.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "ink.h"

namespace tactres {

namespace {

using labels_detail::Blob;

// A glyph's own axes: its height runs along the longer side of its box.
struct Glyph {
  const Blob* blob = nullptr;
  cv::Point2d height_axis;  // (0, 1) or (1, 0)
  double height_px = 0;
  int group = -1;           // the number it joined, -1 while free
};

// Where `other` lies from `g` in g's frame: across its height axis (beside
// it, where the next character of the line would be) and along it.
struct Offset {
  double beside = 0, along = 0;
};
Offset offset(const Glyph& g, const Blob& other) {
  const cv::Point2d d = other.centroid - g.blob->centroid;
  return {std::abs(d.cross(g.height_axis)), std::abs(d.dot(g.height_axis))};
}

bool digit_pair(const Glyph& a, const Glyph& b) {
  if (a.height_axis != b.height_axis) return false;
  const double ratio = b.height_px / a.height_px;
  const Offset o = offset(a, *b.blob);
  return ratio > 0.75 && ratio < 1.33 && o.beside > 0.3 * a.height_px && o.beside < 1.3 * a.height_px &&
         o.along < 0.25 * a.height_px;
}

bool minus_of(const Glyph& digit, const Blob& m) {
  const double len = m.length_px / digit.height_px;
  const Offset o = offset(digit, m);
  return std::abs(m.axis.dot(digit.height_axis)) < 0.5 && len > 0.25 && len < 0.8 &&
         o.beside > 0.4 * digit.height_px && o.beside < 1.3 * digit.height_px && o.along < 0.25 * digit.height_px;
}

// The noise of an image, from the spread of neighbouring pixels'
// differences (robust: edges are few), with a floor for clipped or
// synthetic images that have none.
double noise_sigma(const cv::Mat& g) {
  const cv::Mat d = g.colRange(1, g.cols) - g.colRange(0, g.cols - 1);
  std::vector<float> v(d.begin<float>(), d.end<float>());
  for (float& x : v) x = std::abs(x);
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  double lo = 0, hi = 0;
  cv::minMaxLoc(g, &lo, &hi);
  return std::max(1.4826 * v[v.size() / 2] / std::sqrt(2.0), 1e-3 * (hi - lo));
}

// The search region as every band of character heights thresholds it:
// ink dark (light ink negated), lightly smoothed for the local darkest
// value, and its noise.
struct InkSource {
  cv::Mat g, smooth;
  double noise = 0;
};

InkSource ink_source(const cv::Mat& ink_dark) {
  InkSource s;
  s.g = ink_dark;
  cv::GaussianBlur(s.g, s.smooth, cv::Size(), 0.7);
  s.noise = noise_sigma(s.g);
  return s;
}

// Character heights of kLevelCharPx and more are searched octaves down a
// Gaussian pyramid, where they are still that tall: the mask, the blobs
// and the local extremes cost in proportion to the pixels, and the
// numbers beside a chart's coarse elements are many times taller than
// the finest (dev_02: four bands of 10 ms each at full size). The boxes
// are only where OCR looks (at full size): a pixel or two up there moves
// none of them by more than their padding.
constexpr double kLevelCharPx = 12;

// The octave at which a band starting at `min_char_height_px` is searched.
int band_level(double min_char_height_px) {
  int level = 0;
  while (min_char_height_px * std::exp2(-(level + 1)) >= kLevelCharPx) ++level;
  return level;
}

// The ink of the search region (CV_8U mask): pixels darker than halfway
// from the local mean to the local darkest (over ~3 character heights, so
// uneven light does not matter), where that span is well above the noise
// (plain ground has no ink, however noisy).
cv::Mat ink_mask(const InkSource& s, double max_char_height_px) {
  const int window = 2 * static_cast<int>(std::lround(1.5 * max_char_height_px)) + 1;
  cv::Mat mean;
  cv::blur(s.g, mean, cv::Size(window, window), cv::Point(-1, -1), cv::BORDER_REPLICATE);
  const cv::Mat darkest = labels_detail::local_darkest(s.smooth, window);
  return (s.g < 0.5 * (mean + darkest)) & (mean - darkest > 6 * s.noise);
}

// The index of the candidate nearest to `g` among those that `fits`, or -1.
template <class Fits, class At>
int nearest(const Glyph& g, size_t n, Fits fits, At at) {
  double best = std::numeric_limits<double>::max();
  int best_j = -1;
  for (size_t j = 0; j < n; ++j) {
    if (!fits(j)) continue;
    const double d = cv::norm(at(j) - g.blob->centroid);
    if (d < best) best = d, best_j = static_cast<int>(j);
  }
  return best_j;
}

}  // namespace

void LabelBoxSearch::validate() const {
  if (!(min_char_height_px >= 3 && max_char_height_px >= min_char_height_px && max_char_height_px <= 2000))
    throw std::invalid_argument("labels: need 3 <= min_char_height_px <= max_char_height_px <= 2000");
  if (ink == Ink::automatic) throw std::invalid_argument("labels: find_label_boxes needs Ink::dark or Ink::light");
}

namespace {

// The boxes of one band of character heights (search's min..max), found
// with an ink threshold whose window suits that band.
// `source` is `level` octaves down, and so is `search`'s band of heights;
// the boxes are in full-size image pixels.
std::vector<cv::Rect> boxes_in_band(const InkSource& source, int level, const cv::Rect& region,
                                    const cv::Size& image_size, const LabelBoxSearch& search) {
  const cv::Rect image({0, 0}, image_size);
  const int scale = 1 << level;
  const cv::Mat ink = ink_mask(source, search.max_char_height_px);
  const std::vector<Blob> blobs = labels_detail::find_blobs(ink);
  const std::vector<bool> bars = labels_detail::bar_blobs(blobs);

  std::vector<Glyph> digits;
  std::vector<const Blob*> minus_signs;
  for (size_t i = 0; i < blobs.size(); ++i) {
    const Blob& b = blobs[i];
    if (bars[i]) continue;
    const double h = b.long_side(), w = std::min(b.box.width, b.box.height);
    // No printed digit is a solid round or square blob (the chart's
    // square, dust); a solid short stroke may be a minus sign.
    const bool solid = labels_detail::is_filled_stroke(b, 1, 2.5) && b.fill >= 0.92;
    if (h >= search.min_char_height_px && h <= search.max_char_height_px && w >= 0.12 * h && !solid)
      digits.push_back({&b, b.box.height >= b.box.width ? cv::Point2d(0, 1) : cv::Point2d(1, 0), h});
    if (labels_detail::is_filled_stroke(b, 1.5, 8) && b.length_px < 0.8 * search.max_char_height_px)
      minus_signs.push_back(&b);
  }

  // Two digits side by side first, then a minus sign for a lone digit.
  int next_group = 0;
  for (size_t i = 0; i < digits.size(); ++i) {
    if (digits[i].group >= 0) continue;
    const int j = nearest(
        digits[i], digits.size(),
        [&](size_t j) { return j != i && digits[j].group < 0 && digit_pair(digits[i], digits[j]); },
        [&](size_t j) { return digits[j].blob->centroid; });
    if (j >= 0) digits[i].group = digits[static_cast<size_t>(j)].group = next_group++;
  }
  std::vector<int> minus_group(minus_signs.size(), -1);
  std::vector<bool> used_as_minus(blobs.size(), false);
  for (Glyph& g : digits) {
    if (g.group >= 0) continue;
    const int j = nearest(
        g, minus_signs.size(), [&](size_t j) { return minus_group[j] < 0 && minus_of(g, *minus_signs[j]); },
        [&](size_t j) { return minus_signs[j]->centroid; });
    if (j < 0) continue;
    g.group = minus_group[static_cast<size_t>(j)] = next_group++;
    used_as_minus[static_cast<size_t>(minus_signs[static_cast<size_t>(j)] - blobs.data())] = true;
  }

  std::vector<cv::Rect> boxes(static_cast<size_t>(next_group));
  std::vector<double> heights(boxes.size(), 0);
  for (const Glyph& g : digits) {
    if (used_as_minus[static_cast<size_t>(g.blob - blobs.data())]) continue;  // a minus is no digit of its own
    if (g.group < 0) {
      boxes.push_back(g.blob->box);
      heights.push_back(g.height_px);
      continue;
    }
    boxes[static_cast<size_t>(g.group)] |= g.blob->box;
    heights[static_cast<size_t>(g.group)] = std::max(heights[static_cast<size_t>(g.group)], g.height_px);
  }
  for (size_t j = 0; j < minus_signs.size(); ++j)
    if (minus_group[j] >= 0) boxes[static_cast<size_t>(minus_group[j])] |= minus_signs[j]->box;

  for (size_t i = 0; i < boxes.size(); ++i) {
    const int pad = static_cast<int>(std::ceil(0.25 * heights[i] * scale));
    const cv::Rect full(boxes[i].x * scale, boxes[i].y * scale, boxes[i].width * scale, boxes[i].height * scale);
    boxes[i] = (full + region.tl() - cv::Point(pad, pad) + cv::Size(2 * pad, 2 * pad)) & image;
  }
  return boxes;
}

}  // namespace

// Character heights are searched in bands of a factor 2 (overlapping by a
// quarter, so that a number's two digits fall in one band): one ink
// threshold over the whole range would take its local extremes from the
// largest features (the square, the coarse bars) and lose the small,
// dimmer numbers beside the fine elements.
std::vector<cv::Rect> find_label_boxes(const cv::Mat& luminance, const LabelBoxSearch& search) {
  search.validate();
  const cv::Rect image(0, 0, luminance.cols, luminance.rows);
  const cv::Rect region = search.search_px.empty() ? image : search.search_px & image;
  if (region.width < 3 || region.height < 3) return {};
  // Only the region is converted (a chart's numbers lie within the
  // elements' reach, often a fraction of the frame).
  const cv::Mat grey = labels_detail::to_float_grey(luminance(region));
  // The pyramid of the ink-dark region, and each level's source, made when
  // a band first needs it.
  std::vector<cv::Mat> pyramid = {search.ink == Ink::light ? cv::Mat(-grey) : grey};
  std::vector<std::optional<InkSource>> sources(1);
  std::vector<cv::Rect> boxes;
  for (double lo = search.min_char_height_px; lo <= search.max_char_height_px; lo *= 2) {
    const double hi = std::min(search.max_char_height_px, 2.5 * lo);
    int level = band_level(lo);
    while (level > 0 && (std::min(region.width, region.height) >> level) < 16) --level;
    while (int(pyramid.size()) <= level) {
      cv::Mat down;
      cv::pyrDown(pyramid.back(), down);
      pyramid.push_back(down);
      sources.emplace_back();
    }
    if (!sources[size_t(level)]) sources[size_t(level)] = ink_source(pyramid[size_t(level)]);
    LabelBoxSearch band = search;
    band.min_char_height_px = lo * std::exp2(-level);
    band.max_char_height_px = hi * std::exp2(-level);
    for (const cv::Rect& b : boxes_in_band(*sources[size_t(level)], level, region, luminance.size(), band)) {
      // The same number found in two bands: keep the first.
      const bool seen = std::any_of(boxes.begin(), boxes.end(), [&](const cv::Rect& k) {
        return (k & b).area() > 0.5 * std::min(k.area(), b.area());
      });
      if (!seen) boxes.push_back(b);
    }
    if (hi >= search.max_char_height_px) break;
  }
  std::sort(boxes.begin(), boxes.end(),
            [](const cv::Rect& a, const cv::Rect& b) { return a.y != b.y ? a.y < b.y : a.x < b.x; });
  return boxes;
}

}  // namespace tactres
