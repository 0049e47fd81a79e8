#include <cstdlib>

#include <doctest/doctest.h>

#include "tactres/measure/overlay.h"

using namespace tactres;

namespace {

// A measured element of orientation `o` outlined by the w x h px rectangle
// at (x, y).
ElementResult strip(int group, int element, BarOrientation o, ElementStatus status, bool resolved, double x,
                    double y, double w = 20, double h = 20) {
  ElementResult e = ElementResult::of(group, element, o, 1.0, 3.0);
  e.status = status;
  e.resolved = resolved;
  e.outline_valid = true;
  e.outline_px = {Vec2{x, y}, Vec2{x + w, y}, Vec2{x + w, y + h}, Vec2{x, y + h}};
  return e;
}

cv::Vec3b at(const cv::Mat& img, int x, int y) { return img.at<cv::Vec3b>(y, x); }

// Whether pixel (x, y) shows `bgr`, within what anti-aliasing blends in.
bool shows(const cv::Mat& img, int x, int y, cv::Vec3b bgr) {
  const cv::Vec3b v = at(img, x, y);
  for (int c = 0; c < 3; ++c)
    if (std::abs(int(v[c]) - int(bgr[c])) > 30) return false;
  return true;
}

}  // namespace

TEST_CASE("overlay: strips by status, the limit haloed in white, and a key below the image") {
  // Bright ground above (where the strips are), dark below.
  cv::Mat lum(200, 400, CV_32F, cv::Scalar(0.25));
  lum.rowRange(0, 100).setTo(0.75);
  Measurement m;
  m.elements = {strip(1, 1, BarOrientation::horizontal_bars, ElementStatus::ok, true, 40, 40),
                strip(1, 2, BarOrientation::horizontal_bars, ElementStatus::ok, false, 100, 40),
                strip(1, 3, BarOrientation::horizontal_bars, ElementStatus::damaged, false, 160, 40),
                strip(1, 4, BarOrientation::horizontal_bars, ElementStatus::below_sampling_limit, false, 220, 40)};
  m.horizontal.any_resolved = true;
  m.horizontal.group = 1;
  m.horizontal.element = 1;
  const cv::Mat out = overlay_image(lum, m);
  REQUIRE(out.type() == CV_8UC3);
  CHECK(out.cols == 400);
  CHECK(out.rows > 200);  // the key
  // Each strip's edge in its colour (BGR): green, orange, red, purple.
  CHECK(shows(out, 110, 40, {0, 150, 255}));
  CHECK(shows(out, 170, 40, {40, 40, 230}));
  CHECK(shows(out, 230, 40, {200, 60, 200}));
  // The limit element: its own green on the edge, and four px outside it
  // a white line in black; inside, the capture untouched.
  CHECK(shows(out, 50, 40, {60, 200, 60}));
  CHECK(shows(out, 50, 36, {255, 255, 255}));
  CHECK(shows(out, 50, 35, {0, 0, 0}));
  CHECK(shows(out, 50, 37, {0, 0, 0}));
  CHECK(shows(out, 50, 42, {255, 255, 255}));
  CHECK(shows(out, 110, 35, {255, 255, 255}));  // not the limit: no halo
  // The capture below, and the key's dark grey under the image.
  CHECK(shows(out, 300, 150, {0, 0, 0}));
  CHECK(at(out, 399, out.rows - 1) == cv::Vec3b(32, 32, 32));
}

TEST_CASE("overlay: the limit's halo is as far from a long strip's sides as from its ends, and hides no outline") {
  cv::Mat lum(200, 400, CV_32F, cv::Scalar(0.25));
  lum.rowRange(0, 100).setTo(0.75);  // bright where the strips are
  Measurement m;
  // A 60 x 12 px limit strip, and a neighbour's outline 3 px below it,
  // where the halo's black band runs.
  m.elements = {strip(2, 1, BarOrientation::vertical_bars, ElementStatus::ok, true, 100, 40, 60, 12),
                strip(2, 2, BarOrientation::vertical_bars, ElementStatus::ok, false, 100, 55, 60, 12)};
  m.vertical.any_resolved = true;
  m.vertical.group = 2;
  m.vertical.element = 1;
  const cv::Mat out = overlay_image(lum, m);
  CHECK(shows(out, 130, 36, {255, 255, 255}));  // 4 px above the long side
  CHECK(shows(out, 96, 46, {255, 255, 255}));   // 4 px left of the short side
  CHECK(shows(out, 164, 46, {255, 255, 255}));  // 4 px right of it
  CHECK(shows(out, 130, 55, {0, 150, 255}));    // the neighbour's orange edge, drawn over the halo
}
