#include "finite_pixels.h"

#include <bit>
#include <cstdint>

#include <opencv2/core.hpp>

namespace tactres::locate_detail {

bool all_finite(const cv::Mat& m) {
  CV_Assert(m.type() == CV_32F);
  // An all-ones exponent marks Inf and NaN.
  for (int y = 0; y < m.rows; ++y) {
    const float* row = m.ptr<float>(y);
    std::uint32_t bad = 0;
    for (int x = 0; x < m.cols; ++x)
      bad |= static_cast<std::uint32_t>((std::bit_cast<std::uint32_t>(row[x]) & 0x7f800000u) == 0x7f800000u);
    if (bad) return false;
  }
  return true;
}

}  // namespace tactres::locate_detail
