#include "orientation.h"

#include <algorithm>
#include <stdexcept>

#include <opencv2/core.hpp>

namespace tactres::labels_detail {

namespace {

// Counter-clockwise quarter turns, 0..3.
int quarter_turns(LabelOrientation o) {
  if (o.rotation_deg % 90 != 0) throw std::invalid_argument("labels: rotation_deg must be a multiple of 90");
  return ((o.rotation_deg / 90) % 4 + 4) % 4;
}

// Pixel (x, y) of an image of size `size` after one counter-clockwise
// quarter turn on screen (y down): the top-right pixel becomes the top-left.
cv::Point turn_ccw(cv::Point p, cv::Size& size) {
  const cv::Point q{p.y, size.width - 1 - p.x};
  size = {size.height, size.width};
  return q;
}

cv::Point orient_point(cv::Point p, cv::Size size, LabelOrientation o) {
  if (o.mirrored) p.x = size.width - 1 - p.x;
  for (int i = 0; i < quarter_turns(o); ++i) p = turn_ccw(p, size);
  return p;
}

}  // namespace

cv::Mat orient(const cv::Mat& upright, LabelOrientation o) {
  cv::Mat out = upright.clone();
  if (o.mirrored) cv::flip(out, out, 1);
  switch (quarter_turns(o)) {
    case 1: cv::rotate(out, out, cv::ROTATE_90_COUNTERCLOCKWISE); break;
    case 2: cv::rotate(out, out, cv::ROTATE_180); break;
    case 3: cv::rotate(out, out, cv::ROTATE_90_CLOCKWISE); break;
    default: break;
  }
  return out;
}

cv::Mat make_upright(const cv::Mat& seen, LabelOrientation o) {
  cv::Mat out = seen.clone();
  switch (quarter_turns(o)) {
    case 1: cv::rotate(out, out, cv::ROTATE_90_CLOCKWISE); break;
    case 2: cv::rotate(out, out, cv::ROTATE_180); break;
    case 3: cv::rotate(out, out, cv::ROTATE_90_COUNTERCLOCKWISE); break;
    default: break;
  }
  if (o.mirrored) cv::flip(out, out, 1);
  return out;
}

cv::Rect oriented_box(const cv::Rect& upright_box, cv::Size upright_size, LabelOrientation o) {
  if (upright_box.empty()) return {};
  const cv::Point a = orient_point(upright_box.tl(), upright_size, o);
  const cv::Point b = orient_point(upright_box.br() - cv::Point(1, 1), upright_size, o);
  return {cv::Point(std::min(a.x, b.x), std::min(a.y, b.y)), cv::Point(std::max(a.x, b.x) + 1, std::max(a.y, b.y) + 1)};
}

}  // namespace tactres::labels_detail
