#pragma once
// Turning and mirroring images and boxes by a LabelOrientation (private to
// metrology/labels; the tests use it to render oriented labels).

#include <opencv2/core/mat.hpp>

#include "tactres/labels/label_reader.h"

namespace tactres::labels_detail {

// How `upright` appears in orientation `o`: mirrored first, then turned
// counter-clockwise on screen (label_reader.h, LabelOrientation).
cv::Mat orient(const cv::Mat& upright, LabelOrientation o);

// The inverse of orient(): the upright image of what is seen.
cv::Mat make_upright(const cv::Mat& seen, LabelOrientation o);

// Where a box of the upright image (of size `upright_size`) lies in the
// oriented image.
cv::Rect oriented_box(const cv::Rect& upright_box, cv::Size upright_size, LabelOrientation o);

}  // namespace tactres::labels_detail
