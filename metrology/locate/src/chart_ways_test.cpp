// detect_chart on a frame that shows too little of a real chart for the
// arrangement alone (an even group's element 1 and its column, as on the
// fibre-bundle frames dev_01 and dev_02): it fits as found and, mirrored,
// as an even group's element 6 followed by the odd group's column. The
// printed numbers, read as each way turns them, choose the way and fix the
// group. The frame is drawn here from the real layout (real_chart_layout_test.h)
// with sans-serif numbers, turned and mirrored.

#include <cmath>
#include <string>

#include <doctest/doctest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "chart_detect_internal.h"
#include "fibre_bundle.h"
#include "real_chart_layout_test.h"
#include "tactres/locate/chart_detect.h"

using namespace tactres;
using namespace tactres::locate_detail;
using namespace tactres::locate_test;
using namespace tactres::testing;

namespace {

constexpr double kW = 16;          // px per W (the even group's element 1's bar width)
constexpr int kSuper = 4;          // drawn 4x larger, then area-averaged
constexpr double kOriginX = 34, kOriginY = 10;  // chart (0, 0) in W from the canvas' corner

cv::Point to_canvas(double x_w, double y_w) {
  return {static_cast<int>(std::lround((x_w + kOriginX) * kW * kSuper)),
          static_cast<int>(std::lround((y_w + kOriginY) * kW * kSuper))};
}

void bar(cv::Mat& ink, double x0_w, double y0_w, double x1_w, double y1_w) {
  cv::rectangle(ink, to_canvas(x0_w, y0_w), to_canvas(x1_w, y1_w), cv::Scalar(255), cv::FILLED);
}

// `text` centred at (x, y) W, height_w W tall, strokes a sixth as wide.
void number(cv::Mat& ink, const std::string& text, double x_w, double y_w, double height_w) {
  const int height_px = static_cast<int>(height_w * kW * kSuper);
  const int thickness = std::max(1, height_px / 6);
  const double scale = cv::getFontScaleFromHeight(cv::FONT_HERSHEY_SIMPLEX, height_px, thickness);
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, scale, thickness, &baseline);
  const cv::Point c = to_canvas(x_w, y_w);
  cv::putText(ink, text, {c.x - size.width / 2, c.y + size.height / 2}, cv::FONT_HERSHEY_SIMPLEX, scale,
              cv::Scalar(255), thickness, cv::LINE_8);
}

// Group `group` (even): its element 1 and its column of elements 2-6 with
// their numbers, the group number above the column and above element 1
// (`raised_w` W higher than where the makers print them), upright; dark
// ink on a light ground, slightly blurred.
cv::Mat upright_frame(int group, double raised_w = 0) {
  cv::Mat ink = cv::Mat::zeros(static_cast<int>(44 * kW * kSuper), static_cast<int>(46 * kW * kSuper), CV_8U);
  for (int n = 0; n < 6; ++n) {
    const PairSlot& s = kRealPair[n];
    const double w = std::exp2(-n / 6.0);
    for (int b = -1; b <= 1; ++b) {
      bar(ink, s.hx - 2.5 * w, s.hy + (2 * b - 0.5) * w, s.hx + 2.5 * w, s.hy + (2 * b + 0.5) * w);
      const double vx = s.hx + s.v_dx;
      bar(ink, vx + (2 * b - 0.5) * w, s.hy - 2.5 * w, vx + (2 * b + 0.5) * w, s.hy + 2.5 * w);
    }
    // Element numbers 2-6 left of the column's H triplets, a period tall.
    if (n > 0) number(ink, std::to_string(n + 1), s.hx - 4.5 * w, s.hy, 2.2 * w);
  }
  const std::string g = std::to_string(group);
  const PairSlot& head = kRealPair[1];
  number(ink, g, head.hx + 0.5 * head.v_dx, head.hy - 5 * std::exp2(-1 / 6.0) - raised_w, 2.6);
  const PairSlot& e1 = kRealPair[0];
  number(ink, g, e1.hx + 3.5, e1.hy - 4.5 - raised_w, 2.8);
  cv::Mat img;
  ink.convertTo(img, CV_32F, -0.75 / 255, 0.85);
  cv::resize(img, img, {}, 1.0 / kSuper, 1.0 / kSuper, cv::INTER_AREA);
  return img;
}

// The frame turned by rotation_deg (counter-clockwise on screen) about its
// centre, mirrored first if asked, blurred, seen through a fibre bundle
// of fibre_period_px if > 0, and with a little noise.
cv::Mat seen(const cv::Mat& upright, double rotation_deg, bool mirrored, double fibre_period_px = 0) {
  cv::Mat img = upright.clone();
  if (mirrored) cv::flip(img, img, 1);
  const cv::Mat R = cv::getRotationMatrix2D({0.5f * img.cols, 0.5f * img.rows}, rotation_deg, 1.0);
  cv::warpAffine(img, img, R, img.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0.85));
  cv::GaussianBlur(img, img, {0, 0}, 1.0);
  if (fibre_period_px > 0)
    img.forEach<float>([&](float& v, const int* yx) { v *= float(fibre_transmission(yx[1], yx[0], fibre_period_px)); });
  cv::Mat noise(img.size(), CV_32F);
  cv::RNG rng(7);
  rng.fill(noise, cv::RNG::NORMAL, 0, 0.01);
  return img + noise;
}

}  // namespace

TEST_CASE("chart detection: where the arrangement fits two ways, the printed numbers choose one and fix the group") {
  for (const int group : {2, 6})
    for (const double rotation_deg : {0.0, 20.0, 191.0})
      for (const bool mirrored : {false, true}) {
        CAPTURE(group);
        CAPTURE(rotation_deg);
        CAPTURE(mirrored);
        const ChartDetection d = detect_chart(seen(upright_frame(group), rotation_deg, mirrored), {});
        REQUIRE(d.found);
        CAPTURE(d.anchor_description);
        CHECK(d.elements.size() >= 5);
        REQUIRE(d.anchor == ChartAnchor::printed_numbers);
        CHECK(d.anchor_description.find("ways") != std::string::npos);
        CHECK(d.arrangement.recognised);
        CHECK(d.arrangement.mirrored == mirrored);
        CHECK(d.elements.front().group == group);
        CHECK(d.elements.front().element == 1);
      }
}

TEST_CASE("chart detection: with the group numbers off their places, a way read wrong there is caught") {
  // Raised 4 W above the bands where the makers print them
  // (chart_group_labels.cpp), the group numbers are read under no right
  // way where it puts them, but a wrong way's place may hold another
  // number (a 2 that fits a wrong way with its largest element G2E6).
  // Only the right way's label boxes, which read the 6s, catch it: each
  // way's boxes are read, even where another way's placed numbers fix the
  // group (reading them only where no way's placed numbers fixed it
  // anchored two of these frames G2E6, in session 35's trial). Three are
  // refused as contradictory; one is anchored by its boxes.
  int anchored = 0;
  for (const double rotation_deg : {0.0, 191.0})
    for (const bool mirrored : {false, true}) {
      CAPTURE(rotation_deg);
      CAPTURE(mirrored);
      const ChartDetection d = detect_chart(seen(upright_frame(6, 4.0), rotation_deg, mirrored), {});
      REQUIRE(d.found);
      CAPTURE(d.anchor_description);
      if (d.anchor == ChartAnchor::none) {
        CHECK(d.anchor_description.find("differently") != std::string::npos);  // caught, not unread
        continue;
      }
      ++anchored;
      CHECK(d.elements.front().group == 6);
      CHECK(d.elements.front().element == 1);
      CHECK(d.arrangement.mirrored == mirrored);
    }
  MESSAGE(anchored << " of 4 frames with raised group numbers anchored (all right)");
  CHECK(anchored >= 1);
}

TEST_CASE("chart detection: through a fibre bundle's honeycomb, the numbers anchor the frame right or not at all") {
  // Honeycombs of 4-6 px over the same frame (its finest bars 9 px wide),
  // turned and mirrored: the numbers are read on the cleaned image
  // (without_fine_texture), where a "6" can read as an "8" that fits the
  // parity two groups too high; three readings must fit there. Some frames
  // stay relative (detection loses an element, or too few numbers read);
  // none is anchored wrong.
  int right = 0, wrong = 0;
  for (const double period_px : {4.0, 5.0, 6.0})
    for (const double rotation_deg : {0.0, 20.0, 191.0, 270.0})
      for (const bool mirrored : {false, true}) {
        CAPTURE(period_px);
        CAPTURE(rotation_deg);
        CAPTURE(mirrored);
        const ChartDetection d = detect_chart(seen(upright_frame(6), rotation_deg, mirrored, period_px), {});
        REQUIRE(d.found);
        if (d.anchor == ChartAnchor::none) continue;
        CAPTURE(d.anchor_description);
        const bool ok = d.elements.front().group == 6 && d.elements.front().element == 1 &&
                        d.arrangement.mirrored == mirrored;
        CHECK(ok);
        ok ? ++right : ++wrong;
      }
  MESSAGE(right << " of 24 honeycomb frames anchored right, " << wrong << " wrong");
  CHECK(right >= 6);
}
