// overlay_image (overlay.h): the capture, the strips by status, the limits
// and a key.

#include "tactres/measure/overlay.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

namespace tactres {

namespace {

// BGR. Purple, not grey, for below the sampling limit: grey vanished on a
// bright positive chart.
const cv::Scalar kResolved(60, 200, 60), kNotResolved(0, 150, 255), kGraded(40, 40, 230),
    kBelowSampling(200, 60, 200), kLimit(255, 255, 255), kFiducial(255, 120, 0), kKeyGround(32, 32, 32),
    kKeyText(235, 235, 235);

cv::Scalar status_colour(const ElementResult& e) {
  if (e.status == ElementStatus::ok) return e.resolved ? kResolved : kNotResolved;
  if (e.status == ElementStatus::below_sampling_limit) return kBelowSampling;
  return kGraded;
}

// The capture in grey, scaled by robust percentiles (every other pixel of
// every other row), NaN black.
cv::Mat grey_background(const cv::Mat& lum) {
  std::vector<float> v;
  for (int y = 0; y < lum.rows; y += 2)
    for (int x = 0; x < lum.cols; x += 2)
      if (std::isfinite(lum.at<float>(y, x))) v.push_back(lum.at<float>(y, x));
  float lo = 0, hi = 1;
  if (!v.empty()) {
    std::sort(v.begin(), v.end());
    lo = v[v.size() / 200];
    hi = v[v.size() - 1 - v.size() / 200];
    if (!(hi > lo)) hi = lo + 1;
  }
  cv::Mat grey(lum.size(), CV_8U);
  for (int y = 0; y < lum.rows; ++y)
    for (int x = 0; x < lum.cols; ++x) {
      const float f = lum.at<float>(y, x);
      grey.at<uchar>(y, x) = std::isfinite(f) ? cv::saturate_cast<uchar>(255.0 * (f - lo) / (hi - lo)) : 0;
    }
  cv::Mat out;
  cv::cvtColor(grey, out, cv::COLOR_GRAY2BGR);
  return out;
}

// The convex quadrilateral `q` with every edge moved `by_px` outward along
// its normal (mitred corners): the same gap on a strip's long and short
// sides.
std::array<Vec2, 4> grown(const std::array<Vec2, 4>& q, double by_px) {
  double twice_area = 0;
  for (size_t i = 0; i < 4; ++i) twice_area += cross(q[i], q[(i + 1) % 4]);
  const double outward = twice_area >= 0 ? 1 : -1;  // which side of an edge is outside
  const auto normal = [&](Vec2 a, Vec2 b) {
    const Vec2 d = (1.0 / std::max(norm(b - a), 1e-9)) * (b - a);
    return outward * Vec2{d.y, -d.x};
  };
  std::array<Vec2, 4> out;
  for (size_t i = 0; i < 4; ++i) {
    const Vec2 n1 = normal(q[(i + 3) % 4], q[i]), n2 = normal(q[i], q[(i + 1) % 4]);
    out[i] = q[i] + (by_px / std::max(1 + dot(n1, n2), 1e-3)) * (n1 + n2);
  }
  return out;
}

bool is_limit(const ElementResult& e, const Measurement& m) {
  const Limit& l = e.orientation == BarOrientation::horizontal_bars ? m.horizontal : m.vertical;
  return l.any_resolved && e.group == l.group && e.element == l.element;
}

std::string limit_name(const Limit& l) {
  return l.any_resolved ? fmt::format("G{}E{}", l.group, l.element) : std::string("none");
}

// The key below the image: one swatch and word per colour, then the limits,
// wrapped onto as many lines as the width needs.
cv::Mat key_band(int width_px, double font_scale, int thickness, const Measurement& m) {
  struct Item {
    cv::Scalar colour;
    std::string text;
  };
  const std::vector<Item> items = {
      {kResolved, "resolved"},
      {kNotResolved, "measured, not resolved"},
      {kGraded, "graded (see its status)"},
      {kBelowSampling, "below the sampling limit"},
      {kLimit, fmt::format("the limit: H {}, V {}", limit_name(m.horizontal), limit_name(m.vertical))}};
  const int font = cv::FONT_HERSHEY_SIMPLEX, pad = std::max(4, int(10 * font_scale));
  int baseline = 0;
  const int text_h = cv::getTextSize("Hg", font, font_scale, thickness, &baseline).height;
  const int line_h = text_h + baseline + pad, swatch = text_h;
  // Lay the items out first, to know how many lines the band needs.
  std::vector<cv::Point> at;
  int x = pad, y = pad + text_h;
  for (const Item& it : items) {
    const int w = swatch + pad / 2 + cv::getTextSize(it.text, font, font_scale, thickness, &baseline).width;
    if (x > pad && x + w > width_px - pad) x = pad, y += line_h;
    at.push_back({x, y});
    x += w + 2 * pad;
  }
  cv::Mat band(y + baseline + pad, width_px, CV_8UC3, kKeyGround);
  for (size_t i = 0; i < items.size(); ++i) {
    const cv::Point p = at[i];
    cv::rectangle(band, {p.x, p.y - swatch}, {p.x + swatch, p.y}, items[i].colour, cv::FILLED);
    cv::putText(band, items[i].text, {p.x + swatch + pad / 2, p.y}, font, font_scale, kKeyText, thickness,
                cv::LINE_AA);
  }
  return band;
}

}  // namespace

cv::Mat overlay_image(const cv::Mat& lum, const Measurement& m) {
  cv::Mat out = grey_background(lum);
  const int shift = 4;  // sub-pixel drawing
  // Lines one pixel wide per 1000 px of the shorter side: a 4K frame is
  // looked at scaled down, where 1 px lines vanish.
  const int thickness = std::max(1, int(std::lround(std::min(lum.cols, lum.rows) / 1000.0)));
  auto P = [&](Vec2 p) { return cv::Point(int(std::lround(p.x * 16)), int(std::lround(p.y * 16))); };
  // The limit elements' halos first: a white line in black a few px
  // outside the strip (seen on dark and on bright ground, the strip's bars
  // left in view); then every strip's outline, none hidden under a halo.
  for (const ElementResult& e : m.elements) {
    if (!e.outline_valid || !is_limit(e, m)) continue;
    std::vector<cv::Point> halo;
    for (Vec2 p : grown(e.outline_px, 4.0 * thickness)) halo.push_back(P(p));
    cv::polylines(out, halo, true, cv::Scalar(0, 0, 0), 3 * thickness, cv::LINE_AA, shift);
    cv::polylines(out, halo, true, kLimit, thickness, cv::LINE_8, shift);  // crisp: no white bleeds into the black
  }
  for (const ElementResult& e : m.elements) {
    if (!e.outline_valid) continue;
    std::vector<cv::Point> poly;
    for (Vec2 p : e.outline_px) poly.push_back(P(p));
    cv::polylines(out, poly, true, status_colour(e), thickness, cv::LINE_AA, shift);
  }
  for (const FiducialDetection& f : m.fiducials.discs) {
    cv::circle(out, P(f.centroid_px), 5 * 16 * thickness, kFiducial, thickness, cv::LINE_AA, shift);
    cv::putText(out, f.id, cv::Point(int(f.centroid_px.x) + 8, int(f.centroid_px.y) - 8), cv::FONT_HERSHEY_SIMPLEX,
                0.4, kFiducial, 1, cv::LINE_AA);
  }
  // The key's text scaled with the width (OpenCV's scale 1 is about 22 px
  // tall): 0.35-3, about 8-66 px, so that a 4K frame's key reads scaled down.
  const double font_scale = std::clamp(lum.cols / 1600.0, 0.35, 3.0);
  cv::Mat framed;
  cv::vconcat(out, key_band(lum.cols, font_scale, std::max(1, int(std::lround(font_scale))), m), framed);
  return framed;
}

}  // namespace tactres
