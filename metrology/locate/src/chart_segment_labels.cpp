// The group numbers of the chart tactres generates (seven-segment glyphs,
// targets/glyphs.h), read by fitting each candidate number's rendered ink
// to the image above a column's first element (read_group_label,
// chart_detect_internal.h). Other charts' numbers are read by OCR
// (chart_labels.cpp, chart_group_labels.cpp).
//
// Where the label stands comes from the element's frame, four bar widths
// and more above it, so a small error in the frame's scale or direction
// puts the label 1-3 px off (the shipped example chart: 1-3 px, a
// different way for each label). Fitted there, a "0" explains the image
// hardly better than an "8", which differs by one segment, and the label
// was not read. So each candidate is fitted also at the whole-pixel
// offset where the best of them fits best, found by descent from the
// predicted place.

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "chart_detect_internal.h"
#include "tactres/targets/glyphs.h"
#include "tactres/targets/mil_std_chart.h"

namespace tactres::locate_detail {

namespace {

// A found element's own frame: chart x along H -> V, chart y (down)
// perpendicular to it, sign by handedness; unit = the element's bar width
// in px. The generated chart's triplets all stand H left of V.
struct ElementFrame {
  Vec2 origin_px;  // centre of the H triplet
  Vec2 ex;
  double sign_y = 1;  // -1: mirrored
  double bar_px = 1;
  // sqrt of the H/V period ratio (ChartDetection::hv_period_ratio): a chart
  // seen obliquely is narrower in its x than in its y by its square.
  double root_hv_ratio = 1;
  // Bar widths, relative to the origin -> px.
  Vec2 to_image(Vec2 c) const {
    return origin_px + bar_px * ((c.x / root_hv_ratio) * ex + (sign_y * c.y * root_hv_ratio) * perp(ex));
  }
};

ElementFrame frame_of(const ChartDetection& D, const ChartElement& e, double bar_px, bool mirrored) {
  ElementFrame f;
  f.origin_px = D.patterns[e.h].center_px;
  const Vec2 d = D.patterns[e.v].center_px - f.origin_px;
  f.ex = (1.0 / std::max(norm(d), 1e-9)) * d;
  f.sign_y = mirrored ? -1 : 1;
  f.bar_px = bar_px;
  f.root_hv_ratio = std::sqrt(D.hv_period_ratio);
  return f;
}

// The raster around a label's box (element bar widths, in frame f), with
// room for the blur and the offsets: the pixels inside the box, the same
// for every candidate label and offset.
struct LabelWindow {
  int ix0 = 0, iy0 = 0, nx = 0, ny = 0;
  std::vector<int> inside;  // r * nx + c of the pixels inside the box, in raster order
};

// The image under a window's box moved by a whole-pixel offset.
struct LabelValues {
  std::vector<double> value;  // at the window's inside pixels, in their order
  double sv = 0, svv = 0;     // their sum and sum of squares
};

// Where a box's corners fall in the image, as a polygon in a raster of
// `scale` samples a pixel from (ix0, iy0), in fixed point with kShift bits.
constexpr int kShift = 4;
std::vector<cv::Point> box_polygon(const ElementFrame& f, const RectMm& r, int ix0, int iy0, int scale,
                                   double offset) {
  std::vector<cv::Point> pts;
  for (Vec2 c : {Vec2{r.x0, r.y0}, Vec2{r.x1, r.y0}, Vec2{r.x1, r.y1}, Vec2{r.x0, r.y1}}) {
    const Vec2 q = f.to_image(c);
    pts.push_back({static_cast<int>(std::lround(((q.x - ix0) * scale + offset) * (1 << kShift))),
                   static_cast<int>(std::lround(((q.y - iy0) * scale + offset) * (1 << kShift)))});
  }
  return pts;
}

// The image-axis bounds (px) of a box given in frame f's bar widths.
struct PixelBounds {
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
};

PixelBounds image_bounds(const ElementFrame& f, const RectMm& box) {
  PixelBounds b;
  for (Vec2 c : {Vec2{box.x0, box.y0}, Vec2{box.x1, box.y0}, Vec2{box.x0, box.y1}, Vec2{box.x1, box.y1}}) {
    const Vec2 q = f.to_image(c);
    b.x0 = std::min(b.x0, q.x), b.y0 = std::min(b.y0, q.y), b.x1 = std::max(b.x1, q.x), b.y1 = std::max(b.y1, q.y);
  }
  return b;
}

// nullopt when the box is not fully in view.
std::optional<LabelWindow> label_window(const cv::Mat& img, const ElementFrame& f, const RectMm& box) {
  const auto [x0, y0, x1, y1] = image_bounds(f, box);
  if (x0 < 0 || y0 < 0 || x1 > img.cols - 1 || y1 > img.rows - 1) return std::nullopt;
  constexpr int kPad = 12;
  LabelWindow w;
  w.ix0 = static_cast<int>(std::floor(x0)) - kPad, w.iy0 = static_cast<int>(std::floor(y0)) - kPad;
  w.nx = static_cast<int>(std::ceil(x1)) + kPad - w.ix0 + 1, w.ny = static_cast<int>(std::ceil(y1)) + kPad - w.iy0 + 1;
  cv::Mat inside(w.ny, w.nx, CV_8U, cv::Scalar(0));
  cv::fillConvexPoly(inside, box_polygon(f, box, w.ix0, w.iy0, 1, 0), cv::Scalar(1), cv::LINE_8, kShift);
  for (int r = 0; r < w.ny; ++r)
    for (int c = 0; c < w.nx; ++c)
      if (inside.at<unsigned char>(r, c)) w.inside.push_back(r * w.nx + c);
  return w;
}

// The image under the box moved by (dx, dy) px; nullopt when that leaves
// the image.
std::optional<LabelValues> values_at(const cv::Mat& img, const LabelWindow& w, int dx, int dy) {
  LabelValues out;
  out.value.reserve(w.inside.size());
  for (const int i : w.inside) {
    const int x = w.ix0 + i % w.nx + dx, y = w.iy0 + i / w.nx + dy;
    if (x < 0 || y < 0 || x >= img.cols || y >= img.rows) return std::nullopt;
    const double v = img.at<float>(y, x);
    out.value.push_back(v);
    out.sv += v, out.svv += v * v;
  }
  return out;
}

// A candidate label's ink: the glyphs' coverage of each pixel of the
// window (filled at 3 x 3 samples a pixel, then averaged), blurred by a
// Gaussian of each of kBlursPx, so that a soft image is read as well as a
// sharp one.
constexpr double kBlursPx[] = {0.0, 1.0, 2.0, 3.0, 4.0};

std::vector<cv::Mat> label_inks(const LabelWindow& win, const ElementFrame& f, const std::string& text, Vec2 origin,
                                double height) {
  std::vector<RectMm> rects;
  const double w = 0.6 * height, t = 0.2 * height, gap = 0.3 * height;
  double x = origin.x;
  for (char c : text) {
    append_glyph(c, {x, origin.y}, w, height, t, rects);
    x += w + gap;
  }
  // Sample j of a row at image x = ix0 + (j - 1) / 3.
  constexpr int kSamples = 3;
  cv::Mat fine(kSamples * win.ny, kSamples * win.nx, CV_8U, cv::Scalar(0));
  for (const RectMm& rr : rects)
    cv::fillConvexPoly(fine, box_polygon(f, rr, win.ix0, win.iy0, kSamples, 1), cv::Scalar(255), cv::LINE_8, kShift);
  cv::Mat ink;
  cv::resize(fine, ink, {win.nx, win.ny}, 0, 0, cv::INTER_AREA);
  ink.convertTo(ink, CV_32F, 1.0 / 255);
  // Only pixels within a kernel's reach of the ink can be nonzero: each
  // blur is taken on that part of the window (a one-digit number fills a
  // third of it). Filtered as a region of the whole window, it reads the
  // zeros around it and reflects at the window's edges alone, so every
  // pixel comes out as blurring the whole window would make it.
  const cv::Rect inked = cv::boundingRect(cv::Mat(ink > 0));
  std::vector<cv::Mat> blurred;
  for (const double sigma : kBlursPx) {
    // Each blur into a buffer of its own: into a header of `ink` it would
    // blur ink itself, in place (it once did: the blurs compounded, 0, 1,
    // 2.2, 3.7 and 5.5 px).
    if (sigma == 0) {
      blurred.push_back(ink);
      continue;
    }
    cv::Mat b = cv::Mat::zeros(ink.size(), CV_32F);
    if (!inked.empty()) {  // no ink (a candidate drawn out of the window): zeros, nothing to blur
      // The kernel's size GaussianBlur itself takes for a float image (8 sigma + 1, odd).
      const int ksize = static_cast<int>(std::lround(sigma * 8 + 1)) | 1, reach = ksize / 2;
      const cv::Rect part =
          (inked + cv::Size(2 * reach, 2 * reach) - cv::Point(reach, reach)) & cv::Rect(0, 0, ink.cols, ink.rows);
      cv::Mat region = b(part);
      cv::GaussianBlur(ink(part), region, {ksize, ksize}, sigma);
    }
    blurred.push_back(b);
  }
  return blurred;
}

// How well an ink explains the image: the residual sum of squares of
// value = a + b ink over the box, and b.
struct LabelFit {
  double sse = 1e300, slope = 0, r2 = 0;
  int n = 0;
  int blur = 0;  // index into kBlursPx
};

LabelFit fit_ink(const cv::Mat& ink, const LabelWindow& win, const LabelValues& v) {
  LabelFit out;
  const double s0 = static_cast<double>(win.inside.size());
  const float* k = ink.ptr<float>();
  double s1 = 0, s11 = 0, s1v = 0;
  for (size_t i = 0; i < win.inside.size(); ++i) {
    const double ki = k[win.inside[i]];
    s1 += ki, s11 += ki * ki, s1v += ki * v.value[i];
  }
  const double det = s0 * s11 - s1 * s1;
  if (s0 < 20 || !(det > 1e-9 * s0 * s0)) return out;
  const double b = (s0 * s1v - s1 * v.sv) / det, a = (v.sv - b * s1) / s0;
  const double tss = v.svv - v.sv * v.sv / s0;
  out.sse = std::max(0.0, v.svv - a * v.sv - b * s1v);
  out.slope = b;
  out.r2 = tss > 0 ? 1 - out.sse / tss : 0;
  out.n = static_cast<int>(s0);
  return out;
}

// The best of the blurs at one offset.
LabelFit fit_blurs(const std::vector<cv::Mat>& inks, const LabelWindow& win, const LabelValues& v) {
  LabelFit best;
  for (size_t b = 0; b < inks.size(); ++b) {
    LabelFit f = fit_ink(inks[b], win, v);
    f.blur = static_cast<int>(b);
    if (f.n > 0 && f.sse < best.sse) best = f;
  }
  return best;
}

// Where the label stands: from the predicted place, steps of one pixel to
// the best of the eight neighbours while the fit of `ink` improves, up to
// max_offset_px. `values` caches the image at each offset tried.
std::pair<int, int> best_offset(const cv::Mat& img, const cv::Mat& ink, const LabelWindow& win, double sse0,
                                int max_offset_px,
                                std::map<std::pair<int, int>, std::optional<LabelValues>>& values) {
  auto at = [&](int dx, int dy) -> const std::optional<LabelValues>& {
    auto it = values.find({dx, dy});
    if (it == values.end()) it = values.emplace(std::pair{dx, dy}, values_at(img, win, dx, dy)).first;
    return it->second;
  };
  int dx = 0, dy = 0;
  double best = sse0;
  for (bool moved = true; moved;) {
    moved = false;
    int bx = dx, by = dy;
    for (int sy = -1; sy <= 1; ++sy)
      for (int sx = -1; sx <= 1; ++sx) {
        const int x = dx + sx, y = dy + sy;
        if ((sx == 0 && sy == 0) || std::abs(x) > max_offset_px || std::abs(y) > max_offset_px) continue;
        const std::optional<LabelValues>& v = at(x, y);
        if (!v) continue;
        const LabelFit f = fit_ink(ink, win, *v);
        if (f.n > 0 && f.sse < best) best = f.sse, bx = x, by = y, moved = true;
      }
    dx = bx, dy = by;
  }
  return {dx, dy};
}

// The image a label is read in: `img` itself, or, where its strokes are
// 6 px wide or more, the region around `box` taken octaves down a Gaussian
// pyramid until they are 3-6 px wide, with `f` moved into it (its place
// search, best_offset, then steps whole octave pixels). The fits cost in
// proportion to the label's area: the largest label of the benchmark
// chart (strokes 12 px wide) took 7.6 ms of detection's 43 ms at full
// size, and strokes 3 px wide read as well.
cv::Mat label_octave(const cv::Mat& img, const RectMm& box, ElementFrame& f, double stroke_px) {
  int levels = 0;
  while (stroke_px * std::exp2(-(levels + 1)) >= 3) ++levels;
  if (levels == 0) return img;
  const PixelBounds b = image_bounds(f, box);
  // Room for label_window's pad and the offsets at the octave. Pixel k of
  // the octave is pixel 2^levels k of the crop (pyrDown), wherever the
  // crop starts.
  const int scale = 1 << levels, pad = 24 * scale;
  const int cx0 = std::max(0, static_cast<int>(std::floor(b.x0)) - pad);
  const int cy0 = std::max(0, static_cast<int>(std::floor(b.y0)) - pad);
  const int cx1 = std::min(img.cols, static_cast<int>(std::ceil(b.x1)) + pad);
  const int cy1 = std::min(img.rows, static_cast<int>(std::ceil(b.y1)) + pad);
  if (cx1 - cx0 < 2 * scale || cy1 - cy0 < 2 * scale) return img;
  cv::Mat small = img(cv::Range(cy0, cy1), cv::Range(cx0, cx1));
  for (int l = 0; l < levels; ++l) cv::pyrDown(small, small);
  f.origin_px = from_octave(f.origin_px - Vec2{double(cx0), double(cy0)}, -levels);
  f.bar_px /= scale;
  return small;
}

}  // namespace

// The group number printed above the column that starts with element `e`
// (index n modulo 12 = 1: even group's element 2, top of the left column;
// 6: odd group's element 1, top of the right column): the candidate of the
// known parity whose digits explain the image clearly best, or nullopt.
std::optional<int> read_group_label(const cv::Mat& img, const ChartDetection& D, const ChartElement& e, int n_mod12,
                                    int parity_group, double bar_px) {
  ElementFrame f = frame_of(D, e, bar_px, D.arrangement.mirrored);
  using namespace mil_std;
  // In bar widths of element e, from its H-triplet centre: the block's
  // top-left corner is (-(kHX + 2.5), -2.5); the pair's label stands 4 W
  // above it, W bar widths of the even group's element 1, 2.5 W tall (the
  // odd group's label half that).
  const double W = n_mod12 == 1 ? std::exp2(1.0 / 6) : 2.0;
  const double height = n_mod12 == 1 ? 2.5 * W : 1.25 * W;
  const Vec2 origin{-(kHX + 2.5), -2.5 - 4 * W};
  const RectMm box{origin.x - 0.1 * height, origin.y - 0.1 * height, origin.x + 2.5 * height,
                   origin.y + 1.1 * height};
  const double stroke_px = 0.2 * height * bar_px;
  if (stroke_px < 1.5) return std::nullopt;  // strokes under 1.5 px: not legible
  const double ink_sign = D.light_bars ? 1 : -1;
  const cv::Mat read_img = label_octave(img, box, f, stroke_px);
  const std::optional<LabelWindow> win = label_window(read_img, f, box);
  if (!win) return std::nullopt;
  // Offsets up to a quarter of the digits' height (a stroke and more),
  // within the window's room for the blur.
  const int max_offset_px = std::clamp(static_cast<int>(0.25 * height * f.bar_px), 1, 8);
  // The image at each offset tried (the predicted place first), for all
  // candidates.
  std::map<std::pair<int, int>, std::optional<LabelValues>> values;
  const std::optional<LabelValues>& predicted =
      values.emplace(std::pair{0, 0}, values_at(read_img, *win, 0, 0)).first->second;
  if (!predicted) return std::nullopt;
  // Every candidate where the label is predicted; then where the best of
  // them fits best (the place is the label's, whichever number it is), and
  // each candidate keeps the better of the two.
  std::vector<std::vector<cv::Mat>> inks;
  std::vector<std::pair<LabelFit, int>> fits;
  for (int g = -10; g <= 12; ++g) {
    if (((g - parity_group) % 2 + 2) % 2 != 0) continue;
    inks.push_back(label_inks(*win, f, std::to_string(g), origin, height));
    const LabelFit lf = fit_blurs(inks.back(), *win, *predicted);
    if (lf.n == 0) return std::nullopt;
    fits.push_back({lf, g});
  }
  size_t lead = 0;
  for (size_t c = 1; c < fits.size(); ++c)
    if (fits[c].first.sse < fits[lead].first.sse) lead = c;
  const auto [dx, dy] = best_offset(read_img, inks[lead][fits[lead].first.blur], *win, fits[lead].first.sse,
                                    max_offset_px, values);
  if (dx != 0 || dy != 0)
    for (size_t c = 0; c < fits.size(); ++c) {
      const LabelFit moved = fit_blurs(inks[c], *win, *values.at({dx, dy}));
      if (moved.n > 0 && moved.sse < fits[c].first.sse) fits[c].first = moved;
    }
  std::sort(fits.begin(), fits.end(), [](const auto& a, const auto& b) { return a.first.sse < b.first.sse; });
  const LabelFit& best = fits[0].first;
  if (best.slope * ink_sign <= 0 || best.r2 < 0.5 || !(best.sse < 0.5 * fits[1].first.sse)) return std::nullopt;
  return fits[0].second;
}

}  // namespace tactres::locate_detail
