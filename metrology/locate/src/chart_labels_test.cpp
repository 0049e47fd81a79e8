// without_fine_texture (chart_labels.cpp): a fibre bundle's honeycomb is
// removed from the ground and from the ink, and a numeral's stroke keeps
// its width and most of its contrast.

#include <cmath>

#include <doctest/doctest.h>
#include <opencv2/core.hpp>

#include "chart_detect_internal.h"
#include "fibre_bundle.h"

using namespace tactres::locate_detail;
using namespace tactres::testing;

namespace {

// Bright fibre cores (Gaussian, sigma 1 px) on a hexagonal lattice of
// `period_px` over a dark net, times the chart: ground 1, ink 0.3 in a
// vertical stroke of stroke_px centred at x = 60.
cv::Mat fibre_view(double period_px, double stroke_px, bool with_fibres) {
  cv::Mat img(120, 120, CV_32F);
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x) {
      const double fibres = with_fibres ? fibre_transmission(x, y, period_px) : 1.0;
      const bool ink = std::abs(x - 60) < 0.5 * stroke_px;
      img.at<float>(y, x) = static_cast<float>(fibres * (ink ? 0.3 : 1.0));
    }
  return img;
}

double spread(const cv::Mat& m) {
  cv::Scalar mean, sd;
  cv::meanStdDev(m, mean, sd);
  return sd[0];
}

}  // namespace

TEST_CASE("labels: a fibre bundle's honeycomb is removed, a numeral's stroke kept") {
  const double bar_px = 8, stroke_px = 8;  // a numeral's stroke about a bar wide
  const cv::Mat raw = fibre_view(5, stroke_px, true);
  const cv::Mat out = without_fine_texture(raw, bar_px);
  const cv::Rect ground_px(10, 10, 30, 100), ink_px(59, 10, 3, 100);
  // The ground's texture falls to a fraction of what it was.
  CAPTURE(spread(raw(ground_px)));
  CAPTURE(spread(out(ground_px)));
  CHECK(spread(out(ground_px)) < 0.15 * spread(raw(ground_px)));
  // The stroke stays: most of the ground-to-ink contrast, and its width
  // (where a middle row is darker than halfway), grown by at most two
  // pixels each side where the net's dark meets it.
  const double ground = cv::mean(out(ground_px))[0], ink = cv::mean(out(ink_px))[0];
  CHECK(ground - ink > 0.5 * ground);
  CHECK(spread(out(ink_px)) < 0.2 * (ground - ink));
  int dark_px = 0;
  for (int x = 40; x < 80; ++x) dark_px += out.at<float>(60, x) < 0.5 * (ground + ink);
  CHECK(dark_px >= stroke_px);
  CHECK(dark_px <= stroke_px + 4);
  // A textureless view passes unchanged.
  const cv::Mat clean = fibre_view(5, stroke_px, false);
  CHECK(cv::norm(without_fine_texture(clean, bar_px), clean, cv::NORM_INF) < 1e-6);
}
