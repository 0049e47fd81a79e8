#include "tactres/metrology/chart_detect.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

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
  for (unsigned char u : used) out.unpaired += u ? 0 : 1;
  return out;
}

int floor_div6(int n) { return n >= 0 ? n / 6 : -((-n + 5) / 6); }

// See ChartDetection::predicted_elements.
void predict_column_ends(ChartDetection& D) {
  const double r = std::exp2(-1.0 / 6);
  std::map<int, size_t> by_index;
  for (size_t i = 0; i < D.elements.size(); ++i) by_index[D.elements[i].relative_index] = i;
  std::vector<ChartElement> added;
  for (const auto& [k, i] : by_index) {
    if (by_index.count(k + 1) || !by_index.count(k - 1) || !by_index.count(k - 2)) continue;
    const ChartElement &e0 = D.elements[by_index[k - 2]], &e1 = D.elements[by_index[k - 1]], &e2 = D.elements[i];
    if (D.anchor != ChartAnchor::none && e2.element == 6) continue;  // the group's column ends here
    const Vec2 c0 = D.patterns[e0.h].center_px, c1 = D.patterns[e1.h].center_px, c2 = D.patterns[e2.h].center_px;
    const Vec2 d01 = c1 - c0, d12 = c2 - c1;
    // One column: the second step is the first shrunk by r, in the same direction.
    if (norm(d12 - r * d01) > 0.1 * norm(d12)) continue;
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
  assign(best_g, kept);
  auto level = [&](const ChartElement& e) {
    return std::log(e.period_px) + e.relative_index * std::log(2.0) / 6 - dot(best_g, position(e));
  };
  // A well-sampled element whose period does not fit its index under the
  // field is a mismatch (more than half a step off).
  {
    std::vector<double> levels;
    for (const ChartElement& e : kept)
      if (e.period_px >= 8) levels.push_back(level(e));
    if (levels.size() >= 3) {
      std::nth_element(levels.begin(), levels.begin() + levels.size() / 2, levels.end());
      const double c0 = levels[levels.size() / 2];
      std::erase_if(kept, [&](const ChartElement& e) {
        return e.period_px >= 8 && std::abs(level(e) - c0) > 0.5 * std::log(2.0) / 6;
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
    D.anchor_description =
        "none: groups and elements are relative to the largest element found, which is called group 0 element 1, "
        "and lp/mm are relative to its frequency; give --largest-group or --px-per-mm for absolute values";
  }
  for (ChartElement& e : kept) {
    const int n = D.largest_index + e.relative_index;
    e.group = floor_div6(n);
    e.element = n - 6 * e.group + 1;
  }
  D.elements = std::move(kept);
  predict_column_ends(D);
  D.found = true;
  return D;
}

}  // namespace tactres
