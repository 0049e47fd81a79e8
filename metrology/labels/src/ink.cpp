#include "ink.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace tactres::labels_detail {

namespace {

std::vector<float> finite_values(const cv::Mat& grey) {
  std::vector<float> v;
  v.reserve(grey.total());
  for (int y = 0; y < grey.rows; ++y) {
    const float* row = grey.ptr<float>(y);
    for (int x = 0; x < grey.cols; ++x)
      if (std::isfinite(row[x])) v.push_back(row[x]);
  }
  return v;
}

// The equal-moment rectangle of one blob (see Blob) from its pixel count
// and the sums of x, y, x^2, xy, y^2 over its pixels (relative to its box's
// corner, so that the sums stay small).
void fill_shape(Blob& b, const cv::Vec<double, 5>& sums) {
  const double n = b.area;
  const double mx = sums[0] / n, my = sums[1] / n;
  b.centroid = {b.box.x + mx, b.box.y + my};
  // The 1/12 is a pixel's own variance, so a 1-px-wide stroke is 1 px wide.
  const double cxx = sums[2] / n - mx * mx + 1.0 / 12, cyy = sums[4] / n - my * my + 1.0 / 12;
  const double cxy = sums[3] / n - mx * my;
  const double mean = 0.5 * (cxx + cyy), d = std::sqrt(0.25 * (cxx - cyy) * (cxx - cyy) + cxy * cxy);
  b.length_px = std::sqrt(12 * (mean + d));
  b.width_px = std::sqrt(12 * std::max(mean - d, 1e-9));
  const double angle = 0.5 * std::atan2(2 * cxy, cxx - cyy);
  b.axis = {std::cos(angle), std::sin(angle)};
  b.fill = b.area / (b.length_px * b.width_px);
}

}  // namespace

float quantile(std::vector<float>& values, double q) {
  const auto k = static_cast<std::ptrdiff_t>(q * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[static_cast<size_t>(k)];
}

std::vector<float> values_where(const cv::Mat& grey, const cv::Mat& mask) {
  std::vector<float> v;
  for (int y = 0; y < grey.rows; ++y) {
    const float* g = grey.ptr<float>(y);
    const uchar* m = mask.ptr<uchar>(y);
    for (int x = 0; x < grey.cols; ++x)
      if (m[x]) v.push_back(g[x]);
  }
  return v;
}

cv::Mat to_float_grey(const cv::Mat& image) {
  if (image.empty() || image.channels() != 1)
    throw std::invalid_argument("labels: a patch must be a non-empty single-channel image");
  cv::Mat grey;
  const int depth = image.depth();
  const double scale = depth == CV_8U ? 1.0 / 255 : depth == CV_16U ? 1.0 / 65535 : 1.0;
  image.convertTo(grey, CV_32F, scale);
  // Most images are finite throughout: checked without copying them.
  if (cv::checkRange(grey, true)) return grey;
  std::vector<float> v = finite_values(grey);
  const float fill = v.empty() ? 0.0f : quantile(v, 0.5);
  for (int y = 0; y < grey.rows; ++y) {
    float* row = grey.ptr<float>(y);
    for (int x = 0; x < grey.cols; ++x)
      if (!std::isfinite(row[x])) row[x] = fill;
  }
  return grey;
}

bool stretch_contrast(cv::Mat& grey, double lo_quantile, double hi_quantile) {
  std::vector<float> v = finite_values(grey);
  if (v.empty()) return false;
  const float lo = quantile(v, lo_quantile), hi = quantile(v, hi_quantile);
  if (!(hi > lo)) return false;
  grey = (grey - lo) / (hi - lo);
  cv::min(cv::max(grey, 0.0), 1.0, grey);
  return true;
}

std::vector<Blob> find_blobs(const cv::Mat& mask, cv::Mat* labels_out) {
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  // The moments of every blob in one pass over the labels: a pass over each
  // blob's box cost the sum of the boxes' areas, many times the image's on
  // a textured frame (a fibre bundle's honeycomb: hundreds of blobs).
  std::vector<cv::Vec<double, 5>> sums(static_cast<size_t>(std::max(n, 1)), cv::Vec<double, 5>::all(0));
  for (int y = 0; y < labels.rows; ++y) {
    const int* row = labels.ptr<int>(y);
    for (int x = 0; x < labels.cols; ++x) {
      const int i = row[x];
      if (i == 0) continue;
      const double dx = x - stats.at<int>(i, cv::CC_STAT_LEFT), dy = y - stats.at<int>(i, cv::CC_STAT_TOP);
      sums[static_cast<size_t>(i)] += cv::Vec<double, 5>(dx, dy, dx * dx, dx * dy, dy * dy);
    }
  }
  std::vector<Blob> blobs;
  blobs.reserve(static_cast<size_t>(std::max(n - 1, 0)));
  for (int i = 1; i < n; ++i) {
    Blob b;
    b.label = i;
    b.box = {stats.at<int>(i, cv::CC_STAT_LEFT), stats.at<int>(i, cv::CC_STAT_TOP),
             stats.at<int>(i, cv::CC_STAT_WIDTH), stats.at<int>(i, cv::CC_STAT_HEIGHT)};
    b.area = stats.at<int>(i, cv::CC_STAT_AREA);
    b.touches_border = b.box.x == 0 || b.box.y == 0 || b.box.br().x == mask.cols || b.box.br().y == mask.rows;
    fill_shape(b, sums[static_cast<size_t>(i)]);
    blobs.push_back(b);
  }
  if (labels_out) *labels_out = labels;
  return blobs;
}

bool is_filled_stroke(const Blob& b, double min_aspect, double max_aspect) {
  const double aspect = b.length_px / b.width_px;
  return b.fill >= 0.8 && aspect >= min_aspect && aspect <= max_aspect;
}

std::vector<bool> bar_blobs(const std::vector<Blob>& blobs) {
  std::vector<bool> bar(blobs.size(), false);
  for (size_t i = 0; i < blobs.size(); ++i) {
    const Blob& a = blobs[i];
    if (!is_filled_stroke(a, 2.5, 8)) continue;
    for (size_t j = 0; j < blobs.size() && !bar[i]; ++j) {
      const Blob& b = blobs[j];
      if (j == i || !is_filled_stroke(b, 2.5, 8)) continue;
      const double ratio = b.length_px / a.length_px;
      const double cos_angle = std::abs(a.axis.dot(b.axis));
      const cv::Point2d d = b.centroid - a.centroid;
      const double along = std::abs(d.dot(a.axis)), across = std::abs(d.cross(a.axis));
      bar[i] = ratio > 1 / 1.3 && ratio < 1.3 && cos_angle > std::cos(15 * CV_PI / 180) &&
               across < 3 * a.width_px + 1 && along < 0.5 * a.length_px;
    }
  }
  return bar;
}

// See ink.h. An erosion costs its width per pixel: with windows of
// hundreds of pixels it was three quarters of finding the label boxes of
// dev_02's 1.3 Mpx frame (four bands at 30-55 ms each).
cv::Mat local_darkest(const cv::Mat& g, int window) {
  cv::Mat out;
  const int tile = window / 16;
  if (tile < 2) {
    cv::erode(g, out, cv::getStructuringElement(cv::MORPH_RECT, {window, window}), cv::Point(-1, -1), 1,
              cv::BORDER_REPLICATE);
    return out;
  }
  // Each tile's sample holds the minimum within half a tile of it, so that
  // every pixel lies within some sample's reach (the image's last column
  // too), and the samples' reach together spans the window.
  const int tile_reach = (tile + 1) / 2;
  cv::Mat tile_min, coarse;
  cv::erode(g, tile_min, cv::getStructuringElement(cv::MORPH_RECT, {2 * tile_reach + 1, 2 * tile_reach + 1}),
            cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  // Sampled at the tiles' centres (INTER_NEAREST would take their corners).
  const cv::Size tiles((g.cols + tile - 1) / tile, (g.rows + tile - 1) / tile);
  cv::resize(tile_min, coarse, tiles, 0, 0, cv::INTER_NEAREST_EXACT);
  // The samples stand a little closer than a tile where the image is not a
  // whole number of tiles: the window's half in samples, per axis, from
  // their true spacing.
  const auto half = [&](int px, int n) {
    return std::max(0, static_cast<int>(((window - 1) / 2 - tile_reach) / (static_cast<double>(px) / n)));
  };
  const int half_x = half(g.cols, tiles.width), half_y = half(g.rows, tiles.height);
  cv::erode(coarse, coarse, cv::getStructuringElement(cv::MORPH_RECT, {2 * half_x + 1, 2 * half_y + 1}),
            cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  cv::resize(coarse, out, g.size(), 0, 0, cv::INTER_LINEAR);
  return out;
}

}  // namespace tactres::labels_detail
