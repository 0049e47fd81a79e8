#pragma once
// Shared by the label reader and the label-box finder (private to
// metrology/labels): grey patches to float, contrast normalisation, the ink
// mask and its blobs, and the one rule that tells a bar from a digit.

#include <vector>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

namespace tactres::labels_detail {

// A single-channel image as CV_32F: CV_8U / 255, CV_16U / 65535, floats as
// they are; non-finite pixels become the median of the finite ones (0 when
// there are none). Throws std::invalid_argument for empty or multi-channel.
cv::Mat to_float_grey(const cv::Mat& image);

// The q-quantile (0..1) of non-empty `values`, which are reordered.
float quantile(std::vector<float>& values, double q);

// The pixels of CV_32F `grey` where CV_8U `mask` is set.
std::vector<float> values_where(const cv::Mat& grey, const cv::Mat& mask);

// Maps the lo and hi quantiles of `grey` to 0 and 1 in place, clamped.
// False (and `grey` untouched) when they are equal: nothing is printed.
bool stretch_contrast(cv::Mat& grey, double lo_quantile = 0.005, double hi_quantile = 0.995);

// One 8-connected blob of a binary mask, with the rectangle of equal second
// moments: a filled rectangle has length and width equal to its own and
// fill (area / (length * width)) 1; curved strokes with holes (most digits)
// spread their pixels out, so their fill is well below 1.
struct Blob {
  int label = 0;            // in the label image find_blobs() returns
  cv::Rect box;             // axis-aligned bounding box, px
  int area = 0;             // pixels
  cv::Point2d centroid;
  double length_px = 0;     // along the major axis: sqrt(12 * major variance)
  double width_px = 0;      // across it
  cv::Point2d axis;         // unit vector of the major axis
  double fill = 0;          // area / (length * width)
  bool touches_border = false;
  double long_side() const { return box.width > box.height ? box.width : box.height; }
};

// The blobs of `mask` (CV_8U, nonzero = ink); `labels` receives the CV_32S
// label image when not null.
std::vector<Blob> find_blobs(const cv::Mat& mask, cv::Mat* labels = nullptr);

// A filled straight stroke: fill >= 0.8 and aspect in [min_aspect, max_aspect].
bool is_filled_stroke(const Blob& b, double min_aspect, double max_aspect);

// Which blobs are bars of a USAF triplet: filled strokes of aspect 2.5..8
// (5 when sharp; blur widens thin bars) that have a parallel twin (same
// length within 30 %, axes within 15 deg) whose centre lies across the axis
// within three widths and along it within half a length. A lone stroke may
// be a "1", so it is not a bar.
std::vector<bool> bar_blobs(const std::vector<Blob>& blobs);

// The darkest value of CV_32F `g` within a window x window square about
// each pixel (window odd, borders replicated). Up to 32 px this is the
// erosion itself; beyond, the minimum over the minima of tiles a 16th of the
// window wide, interpolated between the tiles' centres: between the
// erosions by the window + 2 tiles and the window - 4 tiles everywhere, and
// smooth, as the local mean it is compared with.
cv::Mat local_darkest(const cv::Mat& g, int window);

}  // namespace tactres::labels_detail
