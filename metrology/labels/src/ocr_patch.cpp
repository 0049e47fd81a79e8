#include "ocr_patch.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "ink.h"

namespace tactres::labels_detail {

namespace {

// The gates that keep noise and texture from being read (measured on the
// unit tests' labels, the real crops of realdata_labels_test.cpp and 80
// patches of white and smoothed noise):
// - stroke width / character height: synthetic labels in two fonts reach
//   0.31, the bold numerals of real charts 0.30; smoothed noise 0.2-0.9;
// - (ground - ink) / ground spread, medians and MAD: real labels 7.4
//   (the faintest, in a shadow band with speckle) to 53, synthetic ones
//   more; smoothed noise up to 6.3, white noise has no ground at all.
// Noise that passes both is rare, not impossible: a chart-level vote and
// the layout are the caller's further checks.
constexpr double kMaxStrokeShare = 0.35;
constexpr double kMinContrastToNoise = 7;

// Whether the ink is darker than the ground: the ground is what fills the
// patch border; when the border is split (a tight crop through strokes),
// the ink is the smaller class.
bool dark_ink(const cv::Mat& dark_mask) {
  const int w = dark_mask.cols, h = dark_mask.rows;
  const double border_dark = cv::countNonZero(dark_mask.row(0)) + cv::countNonZero(dark_mask.row(h - 1)) +
                             cv::countNonZero(dark_mask.col(0)) + cv::countNonZero(dark_mask.col(w - 1));
  const double share = border_dark / (2.0 * (w + h));
  if (share < 0.35) return true;
  if (share > 0.65) return false;
  return cv::countNonZero(dark_mask) < 0.5 * static_cast<double>(dark_mask.total());
}

// The blobs that may be glyphs: big enough to matter (specks and noise are
// dropped), not bars of a triplet, and not cut by the border when anything
// lies fully inside.
std::vector<Blob> glyph_blobs(const std::vector<Blob>& blobs) {
  int largest = 0;
  for (const Blob& b : blobs) largest = std::max(largest, b.area);
  const std::vector<bool> bars = bar_blobs(blobs);
  std::vector<Blob> kept;
  for (size_t i = 0; i < blobs.size(); ++i)
    if (blobs[i].area >= std::max(3.0, 0.04 * largest) && !bars[i]) kept.push_back(blobs[i]);
  const bool any_inside = std::any_of(kept.begin(), kept.end(), [](const Blob& b) { return !b.touches_border; });
  if (any_inside) std::erase_if(kept, [](const Blob& b) { return b.touches_border; });
  return kept;
}

// `grey` (ink dark) with every ink pixel outside the kept blobs (and a
// one-pixel rim around it, its blurred edge) set to the ground.
void erase_stray_ink(cv::Mat& grey, const cv::Mat& ink, const cv::Mat& labels, const std::vector<Blob>& kept) {
  cv::Mat keep = cv::Mat::zeros(ink.size(), CV_8U);
  for (const Blob& b : kept) keep.setTo(255, labels == b.label);
  cv::Mat stray = ink & ~keep;
  const cv::Mat k = cv::getStructuringElement(cv::MORPH_RECT, {3, 3});
  cv::dilate(stray, stray, k);
  cv::dilate(keep, keep, k);
  grey.setTo(1.0, stray & ~keep);
}

// Printed text stands out of a flat ground; noise and texture do not.
// Some ground must lie 2 px or more from any ink (white noise has none), and
// the ink's median must lie below the ground's by kMinContrastToNoise times
// the ground's spread (median absolute deviation, so speckle on the ground
// does not count).
bool stands_out(const cv::Mat& grey, const cv::Mat& ink_mask) {
  cv::Mat ground_mask;
  cv::dilate(ink_mask, ground_mask, cv::getStructuringElement(cv::MORPH_RECT, {5, 5}));
  ground_mask = ~ground_mask;
  std::vector<float> ground = values_where(grey, ground_mask), ink = values_where(grey, ink_mask);
  if (ink.empty() || ground.size() < 0.05 * static_cast<double>(grey.total())) return false;
  const float ground_level = quantile(ground, 0.5), ink_level = quantile(ink, 0.5);
  for (float& g : ground) g = std::abs(g - ground_level);
  const double spread = 1.4826 * quantile(ground, 0.5);
  return ground_level - ink_level >= kMinContrastToNoise * std::max(spread, 1e-3);
}

// The mean stroke width of binarised text (ink 0), px: 4 x the ink's mean
// distance to the ground, exact for a straight stroke (its distance profile
// is a triangle). Numerals are strokes of 1/8..1/4 of their height; a blob
// of noise or dust is as thick as it is long.
double stroke_width_px(const cv::Mat& binary8) {
  const cv::Mat ink = binary8 == 0;
  cv::Mat distance;
  cv::distanceTransform(ink, distance, cv::DIST_L2, 3);
  return 4 * cv::mean(distance, ink)[0];
}

// Text (ink 0) binarised at Otsu's threshold, or nullopt when its strokes
// are thicker than max_stroke_px (a blob, not a numeral). With
// Counters::reopen, a numeral whose counters filled in gets a second
// threshold: under heavy blur (a fibre bundle's frames, dev_01) the holes
// of a "6" stand half-way between ink and ground, Otsu's threshold puts
// them in the ink, and the "6" becomes a blob. Otsu's threshold within the
// ink class splits the dark strokes from the half-tone counters. It is
// taken only where it keeps the glyph whole: as many pieces as before,
// and at least 3/4 of its height (a blob of texture falls apart into
// fragments, which read as anything).
std::optional<cv::Mat> binarise(const cv::Mat& grey8, Counters counters, double max_stroke_px) {
  cv::Mat binary;
  const double otsu = cv::threshold(grey8, binary, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
  if (stroke_width_px(binary) <= max_stroke_px) return binary;
  if (counters == Counters::keep) return std::nullopt;
  const cv::Mat ink = binary == 0;
  std::vector<uchar> ink_values;
  ink_values.reserve(static_cast<size_t>(cv::countNonZero(ink)));
  for (int y = 0; y < grey8.rows; ++y)
    for (int x = 0; x < grey8.cols; ++x)
      if (ink.at<uchar>(y, x)) ink_values.push_back(grey8.at<uchar>(y, x));
  if (ink_values.size() < 2) return std::nullopt;
  cv::Mat unused, reopened;
  const double within_ink = cv::threshold(cv::Mat(1, static_cast<int>(ink_values.size()), CV_8U, ink_values.data()),
                                          unused, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
  if (!(within_ink < otsu)) return std::nullopt;
  cv::threshold(grey8, reopened, within_ink, 255, cv::THRESH_BINARY);
  const cv::Mat core = reopened == 0;
  cv::Mat component_labels;
  const bool whole = cv::connectedComponents(core, component_labels) == cv::connectedComponents(ink, component_labels) &&
                     cv::boundingRect(core).height >= 0.75 * cv::boundingRect(ink).height;
  if (!whole || stroke_width_px(reopened) > max_stroke_px) return std::nullopt;
  return reopened;
}

}  // namespace

std::optional<OcrPatch> prepare_ocr_patch(const cv::Mat& patch, Ink ink, double ocr_char_height_px,
                                         Counters counters) {
  cv::Mat grey = to_float_grey(patch);
  if (grey.rows < 5 || grey.cols < 5 || !stretch_contrast(grey)) return std::nullopt;
  cv::Mat grey8, dark_mask;
  grey.convertTo(grey8, CV_8U, 255);
  cv::threshold(grey8, dark_mask, 0, 255, cv::THRESH_BINARY_INV | cv::THRESH_OTSU);
  const bool dark = ink == Ink::dark || (ink == Ink::automatic && dark_ink(dark_mask));
  const cv::Mat ink_mask = dark ? dark_mask : ~dark_mask;
  if (!dark) grey = 1.0 - grey;

  if (!stands_out(grey, ink_mask)) return std::nullopt;
  cv::Mat labels;
  const std::vector<Blob> kept = glyph_blobs(find_blobs(ink_mask, &labels));
  if (kept.empty() || kept.size() > 6) return std::nullopt;
  cv::Rect text;
  double char_h = 0;
  for (const Blob& b : kept) {
    text |= b.box;
    char_h = std::max(char_h, b.long_side());
  }
  if (char_h < 5) return std::nullopt;
  erase_stray_ink(grey, ink_mask, labels, kept);

  const int pad = std::max(1, static_cast<int>(std::lround(0.1 * char_h)));
  const cv::Rect crop =
      (text + cv::Size(2 * pad, 2 * pad) - cv::Point(pad, pad)) & cv::Rect(0, 0, grey.cols, grey.rows);
  const double s = ocr_char_height_px / char_h;
  const cv::Size scaled(std::max(1, static_cast<int>(std::lround(crop.width * s))),
                        std::max(1, static_cast<int>(std::lround(crop.height * s))));
  cv::Mat big, big8;
  cv::resize(grey(crop), big, scaled, 0, 0, s > 1 ? cv::INTER_CUBIC : cv::INTER_AREA);
  big.convertTo(big8, CV_8U, 255);
  const std::optional<cv::Mat> binary = binarise(big8, counters, kMaxStrokeShare * ocr_char_height_px);
  if (!binary) return std::nullopt;
  big8 = *binary;

  OcrPatch out;
  const int border = static_cast<int>(std::lround(0.5 * ocr_char_height_px));
  cv::copyMakeBorder(big8, out.image, border, border, border, border, cv::BORDER_CONSTANT, 255);
  out.text_px = text;
  return out;
}

}  // namespace tactres::labels_detail
