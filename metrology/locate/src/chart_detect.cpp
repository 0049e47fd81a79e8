#include "tactres/locate/chart_detect.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <stdexcept>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "tactres/targets/glyphs.h"
#include "tactres/targets/mil_std_chart.h"

namespace tactres {

void ChartDetectOptions::validate() const {
  if (largest_group && (*largest_group < -10 || *largest_group > 12))
    throw std::invalid_argument(fmt::format("--largest-group must be in -10..12, got {}", *largest_group));
  if (largest_element < 1 || largest_element > 6)
    throw std::invalid_argument(fmt::format("--largest-element must be in 1..6, got {}", largest_element));
  if (px_per_mm && !(std::isfinite(*px_per_mm) && *px_per_mm > 0 && *px_per_mm <= 1e5))
    throw std::invalid_argument(fmt::format("--px-per-mm must be in (0, 100000], got {}", *px_per_mm));
  if (largest_group && px_per_mm)
    throw std::invalid_argument("give one anchor: --largest-group or --px-per-mm, not both");
  if (!(min_bar_px >= 0.5 && min_bar_px <= 20))
    throw std::invalid_argument("the minimum bar width must be in [0.5, 20] px");
}

const char* to_string(ChartAnchor a) {
  switch (a) {
    case ChartAnchor::none: return "none";
    case ChartAnchor::largest_group: return "largest_group";
    case ChartAnchor::px_per_mm: return "px_per_mm";
    case ChartAnchor::arrangement: return "arrangement";
  }
  return "none";
}

namespace {

struct Bar {
  Vec2 c;
  Vec2 dir;  // long axis, unit
  double length = 0, width = 0;
  double score = 0;  // closeness to an ideal filled 5:1 rectangle (lower is better)
};

Vec2 perp(Vec2 d) { return {-d.y, d.x}; }

// Noise level: the median absolute deviation of the difference between the
// image and its 3x3 mean, scaled for Gaussian noise. Used to set the
// binarisation margin so that noise alone makes no bars.
double noise_sigma(const cv::Mat& img) {
  cv::Mat smooth;
  cv::blur(img, smooth, {3, 3});
  cv::Mat diff = cv::abs(img - smooth);
  std::vector<float> v;
  for (int y = 1; y < diff.rows - 1; y += 2)
    for (int x = 1; x < diff.cols - 1; x += 2) v.push_back(diff.at<float>(y, x));
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  // For white noise, img - mean3x3 has sd sigma * sqrt(8/9); MAD -> sd is 1.4826.
  return 1.4826 * v[v.size() / 2] / std::sqrt(8.0 / 9.0);
}

// Bar candidates: components of `mask` shaped like a filled rectangle of
// aspect 3..8.
void collect_bars(const cv::Mat& mask, double min_width_px, std::vector<Bar>& out) {
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  std::vector<double> sx(n, 0), sy(n, 0), sxx(n, 0), sxy(n, 0), syy(n, 0);
  std::vector<int> cnt(n, 0);
  const long long max_area = static_cast<long long>(mask.total()) / 8;
  std::vector<unsigned char> wanted(n, 0);
  for (int i = 1; i < n; ++i) {
    const int area = stats.at<int>(i, cv::CC_STAT_AREA);
    wanted[i] = area >= 5 && area <= max_area;
  }
  for (int y = 0; y < labels.rows; ++y) {
    const int* row = labels.ptr<int>(y);
    for (int x = 0; x < labels.cols; ++x) {
      const int l = row[x];
      if (!l || !wanted[l]) continue;
      sx[l] += x;
      sy[l] += y;
      sxx[l] += double(x) * x;
      sxy[l] += double(x) * y;
      syy[l] += double(y) * y;
      ++cnt[l];
    }
  }
  for (int i = 1; i < n; ++i) {
    if (!wanted[i]) continue;
    const double N = cnt[i];
    const double mx = sx[i] / N, my = sy[i] / N;
    const double cxx = sxx[i] / N - mx * mx, cxy = sxy[i] / N - mx * my, cyy = syy[i] / N - my * my;
    const double tr = cxx + cyy, det = cxx * cyy - cxy * cxy;
    const double disc = std::sqrt(std::max(0.0, 0.25 * tr * tr - det));
    const double l1 = 0.5 * tr + disc, l2 = std::max(0.5 * tr - disc, 1e-9);
    // A filled a x b rectangle has variances a^2/12 and b^2/12; a pixel
    // grid adds 1/12 per axis.
    const double length = std::sqrt(12 * std::max(l1 - 1.0 / 12, 1e-9));
    const double width = std::sqrt(12 * std::max(l2 - 1.0 / 12, 1e-9));
    const double aspect = length / width;
    const double fill = N / (length * width);
    if (width < min_width_px || aspect < 3.0 || aspect > 8.0 || fill < 0.7 || fill > 1.3) continue;
    const double angle = 0.5 * std::atan2(2 * cxy, cxx - cyy);
    Bar b;
    b.c = {mx, my};
    b.dir = {std::cos(angle), std::sin(angle)};
    b.length = length;
    b.width = width;
    b.score = std::abs(std::log(aspect / 5.0)) + std::abs(fill - 1.0);
    out.push_back(b);
  }
}

// The same bar found at several window sizes: keep the best-shaped one.
std::vector<Bar> deduplicate(std::vector<Bar> bars) {
  std::sort(bars.begin(), bars.end(), [](const Bar& a, const Bar& b) { return a.score < b.score; });
  std::vector<Bar> kept;
  for (const Bar& b : bars) {
    bool dup = false;
    for (const Bar& k : kept)
      if (norm(k.c - b.c) < 0.6 * std::min(k.width, b.width) && std::abs(std::log(k.width / b.width)) < 0.4) {
        dup = true;
        break;
      }
    if (!dup) kept.push_back(b);
  }
  return kept;
}

bool similar(double a, double b, double tol) { return std::abs(std::log(a / b)) < tol; }

std::vector<BarPattern> find_triplets(const std::vector<Bar>& bars, bool light) {
  std::vector<BarPattern> out;
  for (size_t m = 0; m < bars.size(); ++m) {
    const Bar& B = bars[m];
    const Vec2 n = perp(B.dir);
    int best[2] = {-1, -1};
    double best_cost[2] = {1e300, 1e300};
    for (size_t k = 0; k < bars.size(); ++k) {
      if (k == m) continue;
      const Bar& A = bars[k];
      const Vec2 d = A.c - B.c;
      if (std::abs(d.x) > 3 * B.width + 2 || std::abs(d.y) > 3 * B.width + 2) continue;
      if (!similar(A.width, B.width, 0.35) || !similar(A.length, B.length, 0.3)) continue;
      if (std::abs(dot(A.dir, B.dir)) < std::cos(12 * M_PI / 180)) continue;
      const double along = dot(d, B.dir), across = dot(d, n);
      if (std::abs(along) > 0.25 * B.length) continue;
      const double pitch = std::abs(across) / B.width;
      if (pitch < 1.5 || pitch > 2.7) continue;
      const int side = across > 0 ? 1 : 0;
      const double cost = std::abs(pitch - 2) + std::abs(along) / B.length;
      if (cost < best_cost[side]) {
        best_cost[side] = cost;
        best[side] = static_cast<int>(k);
      }
    }
    if (best[0] < 0 || best[1] < 0) continue;
    const Bar &A = bars[best[0]], &C = bars[best[1]];
    const double a = dot(A.c - B.c, n), c = dot(C.c - B.c, n);
    if (std::abs(a + c) > 0.2 * 0.5 * (c - a)) continue;  // the middle bar sits in the middle
    BarPattern p;
    p.center_px = (1.0 / 3.0) * (A.c + B.c + C.c);
    p.bar_dir = B.dir;
    p.period_px = 0.5 * (c - a);
    p.bar_length_px = (A.length + B.length + C.length) / 3;
    p.light_bars = light;
    p.bar_centers_px = {A.c, B.c, C.c};
    // A bar must not be wider than the period allows (two merged bars).
    if (B.width > 0.8 * p.period_px) continue;
    out.push_back(p);
  }
  return out;
}

struct Pairing {
  std::vector<ChartElement> elements;
  int unpaired = 0;
  std::vector<int> lone;  // the unpaired patterns
};

Pairing pair_patterns(const std::vector<BarPattern>& P) {
  struct Candidate {
    double cost;
    int h, v;
  };
  std::vector<Candidate> cands;
  for (size_t i = 0; i < P.size(); ++i)
    for (size_t j = 0; j < P.size(); ++j) {
      if (i == j) continue;
      const BarPattern &h = P[i], &v = P[j];
      if (!similar(h.period_px, v.period_px, 0.15)) continue;
      if (std::abs(dot(h.bar_dir, v.bar_dir)) > std::sin(15 * M_PI / 180)) continue;
      const Vec2 d = v.center_px - h.center_px;
      const double dist = norm(d), period = 0.5 * (h.period_px + v.period_px);
      if (dist < 2.5 * period || dist > 5.5 * period) continue;
      // The H pattern's bars run along the line to its V partner.
      if (std::abs(dot(d, h.bar_dir)) < std::cos(15 * M_PI / 180) * dist) continue;
      cands.push_back({std::abs(std::log(h.period_px / v.period_px)) + 0.05 * std::abs(dist / period - 3.5),
                       static_cast<int>(i), static_cast<int>(j)});
    }
  std::sort(cands.begin(), cands.end(), [](const Candidate& a, const Candidate& b) { return a.cost < b.cost; });
  std::vector<unsigned char> used(P.size(), 0);
  Pairing out;
  for (const Candidate& c : cands) {
    if (used[c.h] || used[c.v]) continue;
    used[c.h] = used[c.v] = 1;
    ChartElement e;
    e.h = c.h;
    e.v = c.v;
    e.period_px = 0.5 * (P[c.h].period_px + P[c.v].period_px);
    out.elements.push_back(e);
  }
  for (size_t i = 0; i < used.size(); ++i)
    if (!used[i]) ++out.unpaired, out.lone.push_back(static_cast<int>(i));
  return out;
}

int floor_div6(int n) { return n >= 0 ? n / 6 : -((-n + 5) / 6); }

// ---- The standard arrangement (see chart_detect.h) ----

// The arrangement's element positions: groups 0..3 of the generated chart
// (two nested pairs), so that any step of up to 12 elements from an index
// in 0..11 stays inside it. Index n = 6 g + e - 1; centre of the H triplet
// and bar width, mm.
struct ArrangementModel {
  std::vector<Vec2> h_center_mm;
  std::vector<double> bar_width_mm;
};

const ArrangementModel& arrangement_model() {
  static const ArrangementModel model = [] {
    MilStdChartOptions o;
    o.first_group = 0;
    o.last_group = 3;
    const TargetLayout L = make_mil_std_chart(o);
    ArrangementModel m;
    m.h_center_mm.resize(24);
    m.bar_width_mm.resize(24);
    for (const ElementLayout& e : L.elements)
      if (e.orientation == BarOrientation::horizontal_bars) {
        const int n = 6 * e.group + e.element - 1;
        m.h_center_mm[n] = e.extent_mm().center_mm();
        m.bar_width_mm[n] = e.bar_width_mm;
      }
    return m;
  }();
  return model;
}

// A found element's own frame: chart x along H -> V (the H triplet is left
// of the V triplet on the chart), chart y (down) perpendicular to it, sign
// by handedness; unit = the element's bar width in px.
struct ElementFrame {
  Vec2 origin_px;  // centre of the H triplet
  Vec2 ex;
  double sign_y = 1;  // -1: mirrored
  double bar_px = 1;
  Vec2 to_chart(Vec2 q) const {  // px -> bar widths, relative to the origin
    const Vec2 d = q - origin_px;
    return (1.0 / bar_px) * Vec2{dot(d, ex), sign_y * dot(d, perp(ex))};
  }
  Vec2 to_image(Vec2 c) const { return origin_px + bar_px * (c.x * ex + (sign_y * c.y) * perp(ex)); }
};

ElementFrame frame_of(const ChartDetection& D, const ChartElement& e, double bar_px, bool mirrored) {
  ElementFrame f;
  f.origin_px = D.patterns[e.h].center_px;
  const Vec2 d = D.patterns[e.v].center_px - f.origin_px;
  f.ex = (1.0 / std::max(norm(d), 1e-9)) * d;
  f.sign_y = mirrored ? -1 : 1;
  f.bar_px = bar_px;
  return f;
}

// Phase (index of relative index 0, modulo 12) and handedness: the
// hypothesis under which the most steps between found elements (up to 12
// indices apart) land where the arrangement puts them. `bar_px(i)` is the
// bar width of element i from the series (not its binarised period, which
// blur overstates).
template <class BarPx>
void recognise_arrangement(ChartDetection& D, const BarPx& bar_px) {
  const ArrangementModel& M = arrangement_model();
  auto& A = D.arrangement;
  struct Hyp {
    int phase;
    bool mirrored;
    int matched = 0, checked = 0;
  };
  std::vector<Hyp> hyps;
  for (int p = 0; p < 12; ++p)
    for (bool mirrored : {false, true}) {
      Hyp h{p, mirrored};
      for (size_t i = 0; i < D.elements.size(); ++i) {
        const ChartElement& a = D.elements[i];
        const ElementFrame f = frame_of(D, a, bar_px(a), mirrored);
        const int na = a.relative_index + p, base = na - na % 12;
        for (size_t j = 0; j < D.elements.size(); ++j) {
          const ChartElement& b = D.elements[j];
          const int dk = b.relative_index - a.relative_index;
          if (dk < 1 || dk > 12) continue;
          const int ma = na - base, mb = ma + dk;
          const Vec2 want = (1.0 / M.bar_width_mm[ma]) * (M.h_center_mm[mb] - M.h_center_mm[ma]);
          const Vec2 got = f.to_chart(D.patterns[b.h].center_px);
          ++h.checked;
          if (norm(got - want) <= 0.15 * norm(want) + 2.0) ++h.matched;
        }
      }
      hyps.push_back(h);
    }
  std::sort(hyps.begin(), hyps.end(), [](const Hyp& a, const Hyp& b) { return a.matched > b.matched; });
  const Hyp& best = hyps.front();
  A.steps_checked = best.checked;
  A.steps_matched = best.matched;
  const int runner_up = hyps.size() > 1 ? hyps[1].matched : 0;
  if (best.checked < 4 || best.matched < 4 || best.matched < 0.8 * best.checked) {
    A.note = fmt::format("arrangement not recognised: {} of {} steps between the elements found fit the standard "
                         "arrangement at best",
                         best.matched, best.checked);
    return;
  }
  if (best.matched - runner_up < 2) {
    A.note = fmt::format("arrangement not recognised: the elements found fit it in more than one way ({} and {} "
                         "of {} steps); too little of the chart is in view",
                         best.matched, runner_up, best.checked);
    return;
  }
  A.recognised = true;
  A.phase = best.phase;
  A.mirrored = best.mirrored;
}

// How well the label `text` (seven-segment glyphs, as the chart draws
// them) explains the image in the box `box` (element bar widths, in frame
// f): the residual sum of squares of value = a + b ink, and b. The ink is
// the glyphs' pixel coverage blurred by a Gaussian, at the blur (0..4 px)
// that fits best, so that a soft image is read as well as a sharp one.
struct LabelFit {
  double sse = 1e300, slope = 0, r2 = 0;
  int n = 0;
};

LabelFit fit_label(const cv::Mat& img, const ElementFrame& f, const std::string& text, Vec2 origin, double height,
                   const RectMm& box) {
  std::vector<RectMm> rects;
  const double w = 0.6 * height, t = 0.2 * height, gap = 0.3 * height;
  double x = origin.x;
  for (char c : text) {
    append_glyph(c, {x, origin.y}, w, height, t, rects);
    x += w + gap;
  }
  // The box's image bounds, with room for the blur.
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (Vec2 c : {Vec2{box.x0, box.y0}, Vec2{box.x1, box.y0}, Vec2{box.x0, box.y1}, Vec2{box.x1, box.y1}}) {
    const Vec2 q = f.to_image(c);
    x0 = std::min(x0, q.x), y0 = std::min(y0, q.y), x1 = std::max(x1, q.x), y1 = std::max(y1, q.y);
  }
  LabelFit out;
  if (x0 < 0 || y0 < 0 || x1 > img.cols - 1 || y1 > img.rows - 1) return out;  // not fully in view
  constexpr int kPad = 12;
  const int ix0 = static_cast<int>(std::floor(x0)) - kPad, iy0 = static_cast<int>(std::floor(y0)) - kPad;
  const int nx = static_cast<int>(std::ceil(x1)) + kPad - ix0 + 1, ny = static_cast<int>(std::ceil(y1)) + kPad - iy0 + 1;
  cv::Mat ink(ny, nx, CV_32F, cv::Scalar(0));
  cv::Mat inside(ny, nx, CV_8U, cv::Scalar(0));
  for (int r = 0; r < ny; ++r)
    for (int c = 0; c < nx; ++c) {
      const double px = ix0 + c, py = iy0 + r;
      const Vec2 q0 = f.to_chart({px, py});
      inside.at<unsigned char>(r, c) = q0.x >= box.x0 && q0.x <= box.x1 && q0.y >= box.y0 && q0.y <= box.y1;
      double cover = 0;  // 3 x 3 samples a pixel
      for (int sy = -1; sy <= 1; ++sy)
        for (int sx = -1; sx <= 1; ++sx) {
          const Vec2 q = f.to_chart({px + sx / 3.0, py + sy / 3.0});
          for (const RectMm& rr : rects)
            if (q.x >= rr.x0 && q.x < rr.x1 && q.y >= rr.y0 && q.y < rr.y1) {
              cover += 1.0 / 9;
              break;
            }
        }
      ink.at<float>(r, c) = static_cast<float>(cover);
    }
  for (double sigma : {0.0, 1.0, 2.0, 3.0, 4.0}) {
    cv::Mat blurred = ink;
    if (sigma > 0) cv::GaussianBlur(ink, blurred, {0, 0}, sigma);
    double s0 = 0, s1 = 0, s11 = 0, sv = 0, svv = 0, s1v = 0;
    for (int r = 0; r < ny; ++r)
      for (int c = 0; c < nx; ++c) {
        if (!inside.at<unsigned char>(r, c)) continue;
        const double k = blurred.at<float>(r, c), v = img.at<float>(iy0 + r, ix0 + c);
        s0 += 1, s1 += k, s11 += k * k, sv += v, svv += v * v, s1v += k * v;
      }
    const double det = s0 * s11 - s1 * s1;
    if (s0 < 20 || !(det > 1e-9 * s0 * s0)) continue;
    const double b = (s0 * s1v - s1 * sv) / det, a = (sv - b * s1) / s0;
    const double tss = svv - sv * sv / s0, sse = std::max(0.0, svv - a * sv - b * s1v);
    if (sse < out.sse) {
      out.sse = sse;
      out.slope = b;
      out.r2 = tss > 0 ? 1 - sse / tss : 0;
      out.n = static_cast<int>(s0);
    }
  }
  return out;
}

// The group number printed above the column that starts with element `e`
// (index n modulo 12 = 1: even group's element 2, top of the left column;
// 6: odd group's element 1, top of the right column): the candidate of the
// known parity whose digits explain the image clearly best, or nullopt.
std::optional<int> read_group_label(const cv::Mat& img, const ChartDetection& D, const ChartElement& e, int n_mod12,
                                    int parity_group, double bar_px) {
  const ElementFrame f = frame_of(D, e, bar_px, D.arrangement.mirrored);
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
  if (0.2 * height * bar_px < 1.5) return std::nullopt;  // strokes under 1.5 px: not legible
  const double ink_sign = D.light_bars ? 1 : -1;
  std::vector<std::pair<LabelFit, int>> fits;
  for (int g = -10; g <= 12; ++g) {
    if (((g - parity_group) % 2 + 2) % 2 != 0) continue;
    const LabelFit lf = fit_label(img, f, std::to_string(g), origin, height, box);
    if (lf.n == 0) return std::nullopt;
    fits.push_back({lf, g});
  }
  std::sort(fits.begin(), fits.end(), [](const auto& a, const auto& b) { return a.first.sse < b.first.sse; });
  const LabelFit& best = fits[0].first;
  if (best.slope * ink_sign <= 0 || best.r2 < 0.5 || !(best.sse < 0.5 * fits[1].first.sse)) return std::nullopt;
  return fits[0].second;
}

// See ChartDetection::predicted_elements.
void predict_column_ends(ChartDetection& D) {
  const double r = std::exp2(-1.0 / 6);
  std::map<int, size_t> by_index;
  for (size_t i = 0; i < D.elements.size(); ++i) by_index[D.elements[i].relative_index] = i;
  std::vector<ChartElement> added;
  const bool anchored = D.anchor != ChartAnchor::none;
  for (const auto& [k, i] : by_index) {
    if (by_index.count(k + 1) || !by_index.count(k - 1)) continue;
    const ChartElement &e1 = D.elements[by_index[k - 1]], &e2 = D.elements[i];
    if (anchored && e2.element == 6) continue;  // the group's column ends here
    const Vec2 c1 = D.patterns[e1.h].center_px, c2 = D.patterns[e2.h].center_px;
    const Vec2 d12 = c2 - c1;
    if (!anchored) {
      // One column: three in a row, the second step the first shrunk by r,
      // in the same direction.
      if (!by_index.count(k - 2)) continue;
      const Vec2 c0 = D.patterns[D.elements[by_index[k - 2]].h].center_px;
      if (norm(d12 - r * (c1 - c0)) > 0.1 * norm(d12)) continue;
    } else {
      // Two in a row are one column only when the element numbers say so
      // (anchored): an even group's element 1 stands apart, at the lower
      // right; elements 2..6, and an odd group's 1..6, are one column.
      const bool even = ((e2.group % 2) + 2) % 2 == 0;
      if (e1.group != e2.group || (even && e1.element == 1)) continue;
      // And the step is a column step: about (5 + 2.5) bar widths of e1
      // across its bars' length, i.e. along the H triplet's bars' normal.
      const double bar = 0.5 * e1.period_px;
      if (std::abs(norm(d12) / bar - (5 + mil_std::kColumnGap)) > 1.5) continue;
    }
    // Anchored: on to the group's element 6 (the finer ones are the
    // measured ones' neighbours, so they are modelled too); unanchored, the
    // column's end is unknown: one step.
    const int steps = D.anchor != ChartAnchor::none ? 6 - e2.element : 1;
    ChartElement prev = e2, before = e1;
    for (int step = 0; step < steps; ++step) {
      ChartElement next = prev;
      next.relative_index = prev.relative_index + 1;
      next.period_px = prev.period_px * r;
      if (0.5 * next.period_px < 0.8) break;  // far below sampling: nothing to model or measure
      if (by_index.count(next.relative_index)) break;  // found after all
      const int n = D.largest_index + next.relative_index;
      next.group = floor_div6(n);
      next.element = n - 6 * next.group + 1;
      for (int* which : {&next.h, &next.v}) {
        const bool h = which == &next.h;
        BarPattern p = D.patterns[h ? prev.h : prev.v];
        const Vec2 c = p.center_px;
        p.center_px = c + r * (c - D.patterns[h ? before.h : before.v].center_px);
        p.period_px *= r;
        p.bar_length_px *= r;
        p.predicted = true;
        for (Vec2& b : p.bar_centers_px) b = p.center_px + r * (b - c);
        D.patterns.push_back(p);
        *which = static_cast<int>(D.patterns.size()) - 1;
      }
      added.push_back(next);
      before = prev;
      prev = next;
    }
  }
  D.predicted_elements = static_cast<int>(added.size());
  for (const ChartElement& e : added) D.elements.push_back(e);
  std::sort(D.elements.begin(), D.elements.end(),
            [](const ChartElement& a, const ChartElement& b) { return a.relative_index < b.relative_index; });
}

}  // namespace

ChartDetection detect_chart(const cv::Mat& luminance, const ChartDetectOptions& options) {
  options.validate();
  ChartDetection D;
  CV_Assert(luminance.type() == CV_32F);
  // NaN (masked) pixels: the median, so they make no edges.
  cv::Mat img = luminance.clone();
  {
    std::vector<float> finite;
    for (int y = 0; y < img.rows; y += 3)
      for (int x = 0; x < img.cols; x += 3)
        if (std::isfinite(img.at<float>(y, x))) finite.push_back(img.at<float>(y, x));
    if (finite.empty()) {
      D.problem = "the image has no finite pixel";
      return D;
    }
    std::nth_element(finite.begin(), finite.begin() + finite.size() / 2, finite.end());
    const float median = finite[finite.size() / 2];
    img.forEach<float>([&](float& v, const int*) {
      if (!std::isfinite(v)) v = median;
    });
  }
  const double sigma = noise_sigma(img);
  const double mean_level = cv::mean(img)[0];
  // Margin: noise must not make bars, nor the faint texture of a clean print.
  const double margin = std::max(3.0 * sigma, 0.01 * std::abs(mean_level));

  std::vector<Bar> dark, light;
  const int max_window = std::max(7, std::min(img.cols, img.rows) / 2);
  for (int k = 7; k <= max_window; k = 2 * k + 1) {
    cv::Mat mean;
    cv::blur(img, mean, {k, k}, {-1, -1}, cv::BORDER_REFLECT);
    const cv::Mat diff = img - mean;
    cv::Mat m_dark = diff < -margin, m_light = diff > margin;
    collect_bars(m_dark, options.min_bar_px * 0.8, dark);
    collect_bars(m_light, options.min_bar_px * 0.8, light);
  }
  dark = deduplicate(std::move(dark));
  light = deduplicate(std::move(light));
  const std::vector<BarPattern> pd = find_triplets(dark, false), pl = find_triplets(light, true);
  Pairing ed = pair_patterns(pd), el = pair_patterns(pl);
  // A chart has one polarity: the one that shows more elements.
  D.light_bars = el.elements.size() > ed.elements.size();
  D.patterns = D.light_bars ? pl : pd;
  Pairing& pairing = D.light_bars ? el : ed;
  D.unpaired_patterns = pairing.unpaired;
  std::vector<ChartElement> elements = std::move(pairing.elements);
  double separation_periods = 3.5;  // H-to-V centre distance in periods: the chart's median
  // Every element of a chart has the same layout: the H-to-V separation in
  // periods is one number (3.5 on the generated chart). A pair far from the
  // chart's median is two patterns of different elements.
  if (elements.size() >= 3) {
    auto separation = [&](const ChartElement& e) {
      return norm(D.patterns[e.v].center_px - D.patterns[e.h].center_px) / e.period_px;
    };
    std::vector<double> seps;
    for (const ChartElement& e : elements) seps.push_back(separation(e));
    std::nth_element(seps.begin(), seps.begin() + seps.size() / 2, seps.end());
    const double median = seps[seps.size() / 2];
    separation_periods = median;
    std::erase_if(elements, [&](const ChartElement& e) { return std::abs(separation(e) / median - 1) > 0.12; });
  }
  if (elements.empty()) {
    D.problem = D.patterns.empty()
                    ? "no USAF-1951 chart found: no three-bar pattern in the image (is the chart in view, in "
                      "focus and lit?)"
                    : fmt::format("no USAF-1951 chart found: {} three-bar pattern(s) but no element (a horizontal "
                                  "and a vertical pattern of the same size side by side)",
                                  D.patterns.size());
    return D;
  }

  // Relative indices: 6 log2(period ratio) steps from the largest.
  // - Perspective makes the image scale vary over the chart (a 15 degree
  //   tilt of a chart filling the view: +-20 %, more than one step), so the
  //   periods are first divided by a scale field ln s = c1 x + c2 y, fitted
  //   jointly with the indices (a few rounds: indices from the corrected
  //   periods, then the field from the indices).
  // - Blur widens the outer bars of a fine pattern in the binarised image
  //   and so overstates its period; the order of the corrected periods
  //   survives, and no (group, element) appears twice on a chart, so the
  //   indices must rise strictly in that order.
  // - The rounding offset comes from the well-sampled elements (>= 8 px
  //   per period), whose periods the binarisation gets right.
  auto centre = [&](const ChartElement& e) { return 0.5 * (D.patterns[e.h].center_px + D.patterns[e.v].center_px); };
  // ln(scale) = g . (position - image centre) / half the image size.
  const double half = 0.5 * std::max(img.cols, img.rows);
  auto position = [&](const ChartElement& e) {
    const Vec2 c = centre(e);
    return Vec2{(c.x - 0.5 * img.cols) / half, (c.y - 0.5 * img.rows) / half};
  };
  // Indices for a given field gradient: strictly rising in the order of the
  // corrected periods, rounded with the offset of the well-sampled ones.
  auto assign = [&](Vec2 g, std::vector<ChartElement>& out) {
    auto corrected = [&](const ChartElement& e) { return e.period_px * std::exp(-dot(g, position(e))); };
    std::vector<ChartElement> sorted = elements;
    std::sort(sorted.begin(), sorted.end(),
              [&](const ChartElement& a, const ChartElement& b) { return corrected(a) > corrected(b); });
    const double p0 = corrected(sorted.front());
    double offset = 0;
    int n_offset = 0;
    for (const ChartElement& e : sorted)
      if (e.period_px >= 8) {
        const double x = 6 * std::log2(p0 / corrected(e));
        offset += x - std::round(x);
        ++n_offset;
      }
    if (n_offset > 0) offset /= n_offset;
    out.clear();
    double sum = 0, sum2 = 0;
    int n = 0;
    for (ChartElement e : sorted) {
      const double x = 6 * std::log2(p0 / corrected(e)) - offset;
      e.relative_index = static_cast<int>(std::lround(x));
      if (!out.empty()) e.relative_index = std::max(e.relative_index, out.back().relative_index + 1);
      if (e.relative_index - x > 1.6) continue;  // far off the series: not a chart element
      out.push_back(e);
      if (e.period_px >= 8) {  // misfit of the well-sampled ones, in steps
        const double r = e.relative_index - x;
        sum += r, sum2 += r * r, ++n;
      }
    }
    return n > 1 ? sum2 / n - (sum / n) * (sum / n) + 1e-3 * norm(g) : 0.0;
  };
  // The gradient: a grid search, then a finer one around the best; +-30 %
  // scale change over half the image covers a 15-20 degree tilt of a chart
  // that fills the view. A search, not a fit, because wrong indices make a
  // fit converge to a wrong but self-consistent field.
  Vec2 best_g{0, 0};
  std::vector<ChartElement> kept;
  double best_cost = assign(best_g, kept);
  for (double step : {0.03, 0.006}) {
    const Vec2 c = best_g;
    for (int i = -10; i <= 10; ++i)
      for (int j = -10; j <= 10; ++j) {
        const Vec2 g{c.x + i * step, c.y + j * step};
        std::vector<ChartElement> trial;
        const double cost = assign(g, trial);
        if (cost < best_cost - 1e-12) best_cost = cost, best_g = g;
      }
  }
  // A gradient must earn its place: with a dozen elements, some gradient
  // always rounds the noisy periods a little closer to integers, and a
  // spurious one can shift an index by one between elements far apart in
  // the image. A real tilt lowers the misfit many times over (15 degrees:
  // 0.26 -> 0.014); noise and blur-biased periods, by up to 2.7 times
  // (a 4.3 px defocus disc: 0.047 -> 0.0175, with a wrong index). A
  // gradient is kept when it lowers the misfit 4 times or more.
  {
    std::vector<ChartElement> flat;
    const double cost0 = assign({0, 0}, flat);
    if (!(best_cost < 0.25 * cost0)) best_g = {0, 0};
  }
  assign(best_g, kept);
  auto level = [&](const ChartElement& e) {
    return std::log(e.period_px) + e.relative_index * std::log(2.0) / 6 - dot(best_g, position(e));
  };
  // A well-sampled element whose period does not fit its index under the
  // field is a mismatch (more than 3/4 of a step off; blur overstates the
  // binarised period of the finest of them by up to 2/3 of a step, e.g. a
  // 4.3 px defocus disc on an 8 px period).
  {
    std::vector<double> levels;
    for (const ChartElement& e : kept)
      if (e.period_px >= 8) levels.push_back(level(e));
    if (levels.size() >= 3) {
      std::nth_element(levels.begin(), levels.begin() + levels.size() / 2, levels.end());
      const double c0 = levels[levels.size() / 2];
      std::erase_if(kept, [&](const ChartElement& e) {
        return e.period_px >= 8 && std::abs(level(e) - c0) > 0.75 * std::log(2.0) / 6;
      });
    }
  }
  std::sort(kept.begin(), kept.end(),
            [](const ChartElement& a, const ChartElement& b) { return a.relative_index < b.relative_index; });
  if (kept.empty()) {
    D.problem = "no USAF-1951 chart found: the elements found do not follow the 2^(1/6) series";
    return D;
  }
  const int min_index = kept.front().relative_index;
  for (ChartElement& e : kept) e.relative_index -= min_index;
  // An element's bar width from the series and the scale field (the
  // binarised period of a blurred fine pattern is too large).
  double level0 = 0;
  {
    std::vector<double> levels;
    for (const ChartElement& e : kept)
      if (e.period_px >= 8) levels.push_back(level(e));
    if (levels.empty())
      for (const ChartElement& e : kept) levels.push_back(level(e));
    std::nth_element(levels.begin(), levels.begin() + levels.size() / 2, levels.end());
    level0 = levels[levels.size() / 2];
  }
  auto bar_px_of = [&](const ChartElement& e) {
    return 0.5 * std::exp(level0 + dot(best_g, position(e)) - e.relative_index * std::log(2.0) / 6);
  };

  // The anchor.
  if (options.px_per_mm) {
    // The largest element's frequency: px/mm over its period in px.
    const double lp_per_mm = *options.px_per_mm / kept.front().period_px;
    D.largest_index = static_cast<int>(std::lround(6 * std::log2(lp_per_mm)));
    D.anchor = ChartAnchor::px_per_mm;
    D.anchor_description = fmt::format(
        "--px-per-mm {:g}: the largest element found ({:.2f} px per line pair) is {:.3g} lp/mm", *options.px_per_mm,
        kept.front().period_px, lp_per_mm);
  } else if (options.largest_group) {
    D.largest_index = 6 * *options.largest_group + options.largest_element - 1;
    D.anchor = ChartAnchor::largest_group;
    D.anchor_description = fmt::format("--largest-group {}: the largest element found is group {} element {}",
                                       *options.largest_group, *options.largest_group, options.largest_element);
  } else {
    D.largest_index = 0;
    D.anchor = ChartAnchor::none;
    const std::string relative =
        "groups and elements are relative to the largest element found, which is called group 0 element 1, and "
        "lp/mm are relative to its frequency; give --largest-group or --px-per-mm for absolute values";
    // The arrangement: the index modulo 12 and the handedness from the
    // elements' positions, the group from the labels (chart_detect.h).
    D.elements = kept;
    recognise_arrangement(D, bar_px_of);
    auto& A = D.arrangement;
    if (A.recognised) {
      std::optional<int> shift;  // in pairs of groups (12 indices)
      bool agree = true;
      for (const ChartElement& e : kept) {
        const int n = e.relative_index + A.phase, n12 = n % 12;
        if (n12 != 1 && n12 != 6) continue;  // the tops of the columns, under the labels
        const int model_group = n / 6;
        const auto g = read_group_label(img, D, e, n12, model_group, bar_px_of(e));
        if (!g) continue;
        const int s = (*g - model_group) / 2;
        ++A.labels_read;
        if (shift && *shift != s) agree = false;
        shift = s;
      }
      const std::string known = fmt::format(
          "the standard arrangement is recognised ({} of {} steps between elements fit it{}): it fixes each element's number and its "
          "group's parity",
          A.steps_matched, A.steps_checked, A.mirrored ? "; mirrored" : "");
      if (shift && agree) {
        D.largest_index = A.phase + 12 * *shift;
        D.anchor = ChartAnchor::arrangement;
        A.note = known + fmt::format(", and {} group label(s) read from the image fix the group", A.labels_read);
        D.anchor_description = "arrangement: " + A.note;
      } else {
        A.labels_read = shift ? A.labels_read : 0;
        A.note = known + (shift ? ", but the group labels read disagree"
                                : ", but no group label could be read, and nested pairs repeat every 2 groups, so "
                                  "the group is known modulo 2 only");
        D.anchor_description = "none (" + A.note + "): " + relative;
      }
    } else {
      D.anchor_description = "none (" + A.note + "): " + relative;
    }
  }
  for (ChartElement& e : kept) {
    const int n = D.largest_index + e.relative_index;
    e.group = floor_div6(n);
    e.element = n - 6 * e.group + 1;
  }
  D.elements = std::move(kept);
  predict_column_ends(D);

  // Partial elements (ChartElement::partial): a lone, well-sampled pattern
  // whose period falls on the series at an index no element holds. Its
  // orientation on the chart follows from the nearest complete element
  // (chart x runs from an H triplet to its V partner); its partner would
  // stand `separation_periods` away along chart x.
  {
    std::vector<int> taken;
    for (const ChartElement& e : D.elements) taken.push_back(e.relative_index);
    const double step = std::log(2.0) / 6;
    for (int k : pairing.lone) {
      const BarPattern& p = D.patterns[k];
      if (p.period_px < 4) continue;  // a fine pattern's binarised period is not reliable enough to index it
      const Vec2 pos{(p.center_px.x - 0.5 * img.cols) / half, (p.center_px.y - 0.5 * img.rows) / half};
      const double x = (level0 + dot(best_g, pos) - std::log(p.period_px)) / step;
      const int index = static_cast<int>(std::lround(x));
      if (std::abs(x - index) > 0.3 || index < -6 || std::count(taken.begin(), taken.end(), index)) continue;
      const ChartElement* near = nullptr;
      double near_d = 1e300;
      for (const ChartElement& e : D.elements) {
        if (D.patterns[e.h].predicted) continue;
        const double d = norm(D.patterns[e.h].center_px - p.center_px);
        if (d < near_d) near_d = d, near = &e;
      }
      if (!near) continue;
      const Vec2 d = D.patterns[near->v].center_px - D.patterns[near->h].center_px;
      const Vec2 ex = (1.0 / norm(d)) * d;
      const bool is_h = std::abs(dot(p.bar_dir, ex)) > std::cos(30 * M_PI / 180);
      // Where the missing pattern would be, with its strip's margin.
      const Vec2 partner = p.center_px + ((is_h ? 1.0 : -1.0) * separation_periods * p.period_px) * ex;
      const double r = 2.0 * p.period_px;
      const bool outside = partner.x - r < 0 || partner.y - r < 0 || partner.x + r > img.cols - 1 ||
                           partner.y + r > img.rows - 1;
      ChartElement e;
      (is_h ? e.h : e.v) = k;
      e.period_px = p.period_px;
      e.relative_index = index;
      const int n = D.largest_index + index;
      e.group = floor_div6(n);
      e.element = n - 6 * e.group + 1;
      e.partial = outside ? ChartElement::Partial::partner_out_of_view : ChartElement::Partial::partner_not_found;
      e.partial_reason = fmt::format("only the {} pattern was found; the {} pattern {}", is_h ? "horizontal-bar" : "vertical-bar",
                                     is_h ? "vertical-bar" : "horizontal-bar",
                                     outside ? "lies outside the image (the element is partly out of view)"
                                             : "is in the image but was not found there");
      taken.push_back(index);
      D.partial.push_back(e);
    }
    std::sort(D.partial.begin(), D.partial.end(),
              [](const ChartElement& a, const ChartElement& b) { return a.relative_index < b.relative_index; });
  }
  D.found = true;
  return D;
}

}  // namespace tactres
