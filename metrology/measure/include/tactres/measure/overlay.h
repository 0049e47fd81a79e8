#pragma once
// The overlay a person looks at (`tactres measure --overlay`, the watch
// window, the report's thumbnails).

#include <opencv2/core.hpp>

#include "tactres/measure/measurement.h"

namespace tactres {

// The capture in grey (robust 0.5-99.5 % percentiles; NaN black), each
// measured strip outlined in its status's colour (green resolved, orange
// measured but not resolved, red any other graded status, purple below the
// sampling limit), the reported limit element of each orientation haloed
// in white, the fiducials found, and below the image a key: the colours
// and the limits. BGR, 8-bit; as wide as the capture, a little taller.
cv::Mat overlay_image(const cv::Mat& luminance, const Measurement& m);

}  // namespace tactres
