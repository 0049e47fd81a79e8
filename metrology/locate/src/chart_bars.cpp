// Steps 1-3 of detect_chart (chart_detect.h): bars found by binarising
// against the local mean at a ladder of window sizes, three-bar patterns
// made of them, and elements made of pairs of patterns (or why there are
// none).

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "chart_detect_internal.h"

namespace tactres::locate_detail {

namespace {

struct Bar {
  Vec2 c;
  Vec2 dir;  // long axis, unit
  double length = 0, width = 0;
  double score = 0;  // closeness to an ideal filled 5:1 rectangle (lower is better)
};

// 1.4826 x the median of `abs_values` (reordered): the standard deviation
// of zero-mean Gaussian values, robustly; 0 for none.
double robust_sigma(std::vector<float>& abs_values) {
  if (abs_values.empty()) return 0;
  std::nth_element(abs_values.begin(), abs_values.begin() + abs_values.size() / 2, abs_values.end());
  return 1.4826 * abs_values[abs_values.size() / 2];
}

// Noise level: the median absolute deviation of the difference between the
// image and its 3x3 mean, scaled for Gaussian noise. Used to set the
// binarisation margin so that noise alone makes no bars.
double noise_sigma(const cv::Mat& img) {
  // On a lattice of at most 2^16 pixels (every other pixel of every other
  // row at least), with the 3x3 mean taken there alone: the median of 2^16
  // values is known to about 0.5 %, and a full-image blur for a quarter
  // of its values cost 6 % of chart mode (the step rounded down, up to
  // 2.25 x as many pixels, 3 % of detection).
  // Beyond every other pixel, each sampled row starts one pixel further
  // on (cyclically), so that the windows meet every column phase: a fixed
  // lattice of step 4 or 8 would never straddle a JPEG's 8 x 8 block edges,
  // where its noise differs.
  const int step = std::max(2, static_cast<int>(std::ceil(std::sqrt(double(img.total()) / 65536))));
  std::vector<float> v;
  v.reserve(static_cast<size_t>(img.rows / step + 1) * (img.cols / step + 1));
  for (int y = 1; y < img.rows - 1; y += step) {
    const float* r0 = img.ptr<float>(y - 1);
    const float* r1 = img.ptr<float>(y);
    const float* r2 = img.ptr<float>(y + 1);
    const int stagger = step > 2 ? (y / step) % step : 0;
    for (int x = 1 + stagger; x < img.cols - 1; x += step) {
      const float sum = r0[x - 1] + r0[x] + r0[x + 1] + r1[x - 1] + r1[x] + r1[x + 1] + r2[x - 1] + r2[x] + r2[x + 1];
      v.push_back(std::abs(r1[x] - sum / 9));
    }
  }
  // For white noise, img - mean3x3 has sd sigma * sqrt(8/9).
  return robust_sigma(v) / std::sqrt(8.0 / 9.0);
}

// Bar candidates: 8-connected components of `mask` shaped like a filled
// rectangle of aspect 3..8.
void collect_bars(const cv::Mat& mask, double min_width_px, std::vector<Bar>& out) {
  std::vector<MaskRun> runs;
  const std::vector<int> root = run_components(mask, runs);
  // Pixel count and moments per component, summed run by run in closed
  // form (integers, exact in double).
  const size_t n = runs.size();
  std::vector<double> sx(n, 0), sy(n, 0), sxx(n, 0), sxy(n, 0), syy(n, 0), cnt(n, 0);
  for (size_t i = 0; i < n; ++i) {
    const MaskRun& r = runs[i];
    const int c = root[i];
    const long long a = r.x0, b = r.x1, len = b - a + 1, y = r.y;
    const long long sum_x = (a + b) * len / 2;
    const long long sum_xx = (b * (b + 1) * (2 * b + 1) - (a - 1) * a * (2 * a - 1)) / 6;
    sx[c] += double(sum_x);
    sy[c] += double(len * y);
    sxx[c] += double(sum_xx);
    sxy[c] += double(sum_x * y);
    syy[c] += double(len * y * y);
    cnt[c] += double(len);
  }
  const double max_area = static_cast<double>(mask.total() / 8);
  for (size_t i = 0; i < n; ++i) {
    if (root[i] != static_cast<int>(i) || cnt[i] < 5 || cnt[i] > max_area) continue;
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
  // Ties in shape broken by place, so that the order the components were
  // labelled in never matters.
  std::sort(bars.begin(), bars.end(), [](const Bar& a, const Bar& b) {
    return std::tuple(a.score, a.c.y, a.c.x, a.width) < std::tuple(b.score, b.c.y, b.c.x, b.width);
  });
  std::vector<Bar> kept;
  // The kept bars by x: a duplicate lies within 0.6 of b's width of b, so
  // only that slice is searched (thousands of candidates on a textured frame).
  std::multimap<double, size_t> by_x;
  for (const Bar& b : bars) {
    bool dup = false;
    const double r = 0.6 * b.width;
    for (auto it = by_x.lower_bound(b.c.x - r); it != by_x.end() && it->first <= b.c.x + r && !dup; ++it) {
      const Bar& k = kept[it->second];
      dup = norm(k.c - b.c) < 0.6 * std::min(k.width, b.width) && std::abs(std::log(k.width / b.width)) < 0.4;
    }
    if (dup) continue;
    by_x.emplace(b.c.x, kept.size());
    kept.push_back(b);
  }
  return kept;
}

bool similar(double a, double b, double tol) { return std::abs(std::log(a / b)) < tol; }

// Three-bar patterns: each bar with the best-fitting bar of its size and
// direction one period (about 2 bar widths) away on either side.
std::vector<BarPattern> find_triplets(const std::vector<Bar>& bars, bool light) {
  std::vector<BarPattern> out;
  // The bars by x: a neighbour lies within 3 bar widths + 2 px in x, so only
  // that slice is searched (a textured 12 Mpx frame has tens of thousands of
  // candidates), in index order as a full scan would meet them.
  std::vector<std::pair<double, size_t>> by_x;
  for (size_t k = 0; k < bars.size(); ++k) by_x.push_back({bars[k].c.x, k});
  std::sort(by_x.begin(), by_x.end());
  std::vector<size_t> near;
  for (size_t m = 0; m < bars.size(); ++m) {
    const Bar& B = bars[m];
    const Vec2 n = perp(B.dir);
    int best[2] = {-1, -1};
    double best_cost[2] = {1e300, 1e300};
    const double reach = 3 * B.width + 2;
    near.clear();
    for (auto it = std::lower_bound(by_x.begin(), by_x.end(), std::pair<double, size_t>{B.c.x - reach, 0});
         it != by_x.end() && it->first <= B.c.x + reach; ++it)
      near.push_back(it->second);
    std::sort(near.begin(), near.end());
    for (const size_t k : near) {
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
    // The three bars' mean direction (each from its component's second
    // moments, signed as the middle one's): a blob of texture on one bar's
    // edge turns that bar by degrees (a fluorescent particle turned dev_16's
    // middle bar by 7 deg, and its strip smeared the bars), the mean of
    // three by less.
    const Vec2 dir = B.dir + (dot(A.dir, B.dir) >= 0 ? 1.0 : -1.0) * A.dir + (dot(C.dir, B.dir) >= 0 ? 1.0 : -1.0) * C.dir;
    p.bar_dir = (1.0 / norm(dir)) * dir;
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

// The square root of the linear luminance (ImageScale::stabilised).
cv::Mat stabilised(const cv::Mat& linear) {
  cv::Mat out;
  cv::sqrt(cv::max(linear, 0.0), out);
  return out;
}

// The robust spread of a local-contrast image (robust_sigma, on every
// third pixel of every third row).
double local_contrast_sigma(const cv::Mat& diff) {
  std::vector<float> v;
  v.reserve(static_cast<size_t>(diff.rows / 3 + 1) * (diff.cols / 3 + 1));
  for (int y = 0; y < diff.rows; y += 3) {
    const float* row = diff.ptr<float>(y);
    for (int x = 0; x < diff.cols; x += 3) v.push_back(std::abs(row[x]));
  }
  return robust_sigma(v);
}

// Bar candidates in `img` at windows 7 and 15 px: dark ones into `dark`,
// light ones into `light` (a null pointer: that polarity is not searched).
// With `contrast_sigmas` > 0 the margin is at least that many robust
// sigmas of each window's local contrast (a smoothed texture's mottle).
void collect_bars_at(const cv::Mat& img, double margin, double min_width_px, std::vector<Bar>* dark,
                     std::vector<Bar>* light, double contrast_sigmas) {
  std::vector<int> windows{7};
  if (15 <= std::min(img.cols, img.rows) / 2) windows.push_back(15);
  std::vector<cv::Mat> contrast;
  cv::Mat mask;  // shared by the windows
  local_contrast(img, windows, contrast);
  for (const cv::Mat& diff : contrast) {
    const double m = contrast_sigmas > 0 ? std::max(margin, contrast_sigmas * local_contrast_sigma(diff)) : margin;
    if (dark) {
      cv::compare(diff, -m, mask, cv::CMP_LT);
      collect_bars(mask, min_width_px, *dark);
    }
    if (light) {
      cv::compare(diff, m, mask, cv::CMP_GT);
      collect_bars(mask, min_width_px, *light);
    }
  }
}

// Bars found `level` octaves down the pyramid, in full-resolution pixels.
void to_full_resolution(std::vector<Bar>& bars, int level) {
  const double scale = std::exp2(level);
  for (Bar& b : bars) {
    b.c = from_octave(b.c, level);
    b.length *= scale;
    b.width *= scale;
  }
}

// How many elements (two perpendicular patterns side by side) bar
// candidates of one polarity make.
size_t element_count(const std::vector<Bar>& bars, bool light) {
  return pair_patterns(find_triplets(deduplicate(bars), light)).elements.size();
}

// Bar candidates of each polarity in `img` against the local mean over a
// ladder of windows 7, 15, 30, 60, ... px, up to half the image. A window
// of k px at full resolution and one of k/2 px an octave down a Gaussian
// pyramid find the same bars, so every window beyond 15 px is taken down
// the pyramid at 7 or 15 px: the ladder costs about 2.7 full-resolution
// passes instead of 7 (binarisation was 80 % of detecting a chart on a
// 1.5 Mpx frame). The pyramid also removes texture finer than a bar (a
// fibre bundle's honeycomb, 4.75-6.4 px on dev_01/02; laser speckle), which
// cuts bars into fragments at full resolution: two octaves down a 5 px
// period keeps 2 % of its amplitude while bars 6 px wide stay bars.
void collect_all_bars(const cv::Mat& img, double min_bar_px, double contrast_sigmas, std::vector<Bar>& dark,
                      std::vector<Bar>& light) {
  const double mean_level = cv::mean(img)[0];
  // Margin: noise must not make bars, nor the faint texture of a clean
  // print. Each octave has its own noise (the pyramid smooths it). 2 sigma:
  // white noise then marks 2.3 % of the pixels, whose rare 5-pixel
  // elongated clusters the three-bar geometry (three alike bars at a
  // pitch of 2 widths, the middle one in the middle) rejects. On a
  // speckled frame (two-photon fluorescence, dev_16) the texture counts as
  // noise, and at the octave whose window spans the triplet its bars stand
  // only 2-3 sigma below the local mean: a 3 sigma margin found none.
  auto margin = [&](const cv::Mat& level_img) {
    return std::max(2.0 * noise_sigma(level_img), 0.01 * std::abs(mean_level));
  };
  // The octaves down the pyramid first.
  std::vector<Bar> coarse_dark, coarse_light;
  cv::Mat level_img = img;
  for (int level = 1;; ++level) {
    cv::pyrDown(level_img, level_img);
    if (std::min(level_img.cols, level_img.rows) < 32) break;
    std::vector<Bar> d, li;
    collect_bars_at(level_img, margin(level_img), std::max(1.5, 0.8 * min_bar_px * std::exp2(-level)), &d, &li,
                    contrast_sigmas);
    to_full_resolution(d, level);
    to_full_resolution(li, level);
    coarse_dark.insert(coarse_dark.end(), d.begin(), d.end());
    coarse_light.insert(coarse_light.end(), li.begin(), li.end());
  }
  // Then full resolution, which costs three times the octaves together. A
  // chart has one polarity. Where the octaves show two or more elements of
  // one polarity and none of the other (every chart of tests/realdata that
  // shows two), the other is not searched there: a sixth of detecting the
  // generated chart. One element is not taken as evidence: a stray one of
  // the wrong polarity must not hide a chart too fine for the octaves.
  const size_t n_dark = element_count(coarse_dark, false), n_light = element_count(coarse_light, true);
  const bool dark_only = n_dark >= 2 && n_light == 0, light_only = n_light >= 2 && n_dark == 0;
  collect_bars_at(img, margin(img), min_bar_px * 0.8, light_only ? nullptr : &dark, dark_only ? nullptr : &light,
                  contrast_sigmas);
  dark.insert(dark.end(), coarse_dark.begin(), coarse_dark.end());
  light.insert(light.end(), coarse_light.begin(), coarse_light.end());
}

}  // namespace

// local_contrast (chart_detect_internal.h): cv::blur sums every window size
// anew (2.1 ms a window on a 1.5 Mpx frame, with both image scales and the
// octaves 11 of them a frame); one integral image serves every window.
// Band by band of kBandRows rows (each band's integral with the rows the
// windows reach beyond it): a whole frame's integral in double (12 MB at
// 1.5 Mpx) cost its page faults in every process's first frame, 5 ms more
// than it saved there, where a band's stays in cache. The border is
// BORDER_REFLECT at the image's edges only (copyMakeBorder reads a band's
// neighbour rows from the image itself). Sums in double, as cv::blur's;
// the mean is rounded to float before it is subtracted, as cv::blur's
// output would be.
void local_contrast(const cv::Mat& img, const std::vector<int>& windows, std::vector<cv::Mat>& contrast) {
  constexpr int kBandRows = 64;
  const int pad = *std::max_element(windows.begin(), windows.end()) / 2;
  contrast.resize(windows.size());
  for (cv::Mat& c : contrast) c.create(img.size(), CV_32F);
  cv::Mat padded, sums;  // one band's, reused
  for (int y0 = 0; y0 < img.rows; y0 += kBandRows) {
    const int y1 = std::min(img.rows, y0 + kBandRows);
    cv::copyMakeBorder(img.rowRange(y0, y1), padded, pad, pad, pad, pad, cv::BORDER_REFLECT);
    cv::integral(padded, sums, CV_64F);
    for (size_t i = 0; i < windows.size(); ++i) {
      const int k = windows[i], r = k / 2;
      const double inv_area = 1.0 / (double(k) * k);
      for (int y = y0; y < y1; ++y) {
        // sums(j, i): the sum of the band's padded rows < j and columns < i.
        const double* top = sums.ptr<double>(y - y0 + pad - r) + (pad - r);
        const double* bottom = sums.ptr<double>(y - y0 + pad + r + 1) + (pad - r);
        const float* in = img.ptr<float>(y);
        float* out = contrast[i].ptr<float>(y);
        for (int x = 0; x < img.cols; ++x)
          out[x] = in[x] - static_cast<float>((bottom[x + k] - bottom[x] - top[x + k] + top[x]) * inv_area);
      }
    }
  }
}

PatternsFound find_patterns(const cv::Mat& linear, double min_bar_px, ImageScale scale, double contrast_sigmas) {
  std::vector<Bar> dark, light;
  const cv::Mat img = scale == ImageScale::stabilised ? stabilised(linear) : linear;
  collect_all_bars(img, min_bar_px, contrast_sigmas, dark, light);
  dark = deduplicate(std::move(dark));
  light = deduplicate(std::move(light));
  return {find_triplets(dark, false), find_triplets(light, true)};
}

namespace {

// A pattern pair that may be one element, judged by its geometry alone:
// perpendicular, 2.5-5.5 periods apart, the H pattern's bars running along
// the line to its V partner.
struct PairCandidate {
  int h = 0, v = 0;
  double ln_ratio = 0;         // ln(H period / V period)
  double separation_cost = 0;  // how far the distance is from 3.5 periods, and the centres from level
};

std::vector<PairCandidate> pair_candidates(const std::vector<BarPattern>& P, double max_ln_ratio) {
  std::vector<PairCandidate> out;
  for (size_t i = 0; i < P.size(); ++i)
    for (size_t j = 0; j < P.size(); ++j) {
      if (i == j) continue;
      const BarPattern &h = P[i], &v = P[j];
      const double ln_ratio = std::log(h.period_px / v.period_px);
      if (std::abs(ln_ratio) >= max_ln_ratio) continue;
      if (std::abs(dot(h.bar_dir, v.bar_dir)) > std::sin(15 * M_PI / 180)) continue;
      const Vec2 d = v.center_px - h.center_px;
      const double dist = norm(d), period = 0.5 * (h.period_px + v.period_px);
      if (dist < 2.5 * period || dist > 5.5 * period) continue;
      if (std::abs(dot(d, h.bar_dir)) < std::cos(15 * M_PI / 180) * dist) continue;
      // An element's two patterns stand side by side, their centres level:
      // a triplet found a period off along its column (two of its bars and
      // a shoulder of the ground beside them) pairs level no more.
      const double offset_periods = std::abs(dot(d, perp(h.bar_dir))) / period;
      out.push_back({static_cast<int>(i), static_cast<int>(j), ln_ratio,
                     0.05 * (std::abs(dist / period - 3.5) + offset_periods)});
    }
  return out;
}

// Elements from the candidates whose period ratio lies within 0.15 of
// exp(ln_ratio) on the log scale (1 seen face on, where an element's two
// patterns match within a few per cent): the best-fitting pairs first,
// each pattern in one element at most.
Pairing pair_at_ratio(const std::vector<BarPattern>& P, const std::vector<PairCandidate>& candidates,
                      double ln_ratio) {
  std::vector<std::pair<double, const PairCandidate*>> ranked;
  for (const PairCandidate& c : candidates) {
    const double mismatch = std::abs(c.ln_ratio - ln_ratio);
    if (mismatch < 0.15) ranked.push_back({mismatch + c.separation_cost, &c});
  }
  std::stable_sort(ranked.begin(), ranked.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<unsigned char> used(P.size(), 0);
  Pairing out;
  out.ln_hv_ratio = ln_ratio;
  for (const auto& [cost, c] : ranked) {
    if (used[c->h] || used[c->v]) continue;
    used[c->h] = used[c->v] = 1;
    ChartElement e;
    e.h = c->h;
    e.v = c->v;
    e.period_px = 0.5 * (P[c->h].period_px + P[c->v].period_px);
    out.elements.push_back(e);
  }
  for (size_t i = 0; i < used.size(); ++i)
    if (!used[i]) ++out.unpaired, out.lone.push_back(static_cast<int>(i));
  return out;
}

// The median ln(H period / V period) of the elements.
double median_ln_ratio(const std::vector<BarPattern>& P, const std::vector<ChartElement>& elements) {
  std::vector<double> r;
  for (const ChartElement& e : elements) r.push_back(std::log(P[e.h].period_px / P[e.v].period_px));
  std::nth_element(r.begin(), r.begin() + r.size() / 2, r.end());
  return r[r.size() / 2];
}

}  // namespace

// A chart seen obliquely is foreshortened across the tilt's axis: its H
// and V triplets differ in period by the cosine of the tilt (13 % at 30
// degrees, 0.14 on the log scale, about a pairing's whole tolerance). The
// patterns are paired as seen face on, and at H/V ratios up to 1.42 either
// way (a 45 degree tilt) in steps of a third of the tolerance; a ratio
// other than 1 is taken only where it pairs more patterns than face on,
// and at least three (two say little of the whole chart: on dev_12 the
// field's distortion near the lit disc's rim squeezes one element's H
// triplet by 15 % against its V triplet, and its neighbour's by 7 %),
// and then refined to the median of the pairs it made.
Pairing pair_patterns(const std::vector<BarPattern>& P) {
  constexpr double kRatioStep = 0.05;  // ln: a third of the pairing's tolerance
  constexpr int kRatioSteps = 7;       // either way: ln 1.42 = 0.35
  constexpr size_t kMinForeshortenedElements = 3;
  const std::vector<PairCandidate> candidates = pair_candidates(P, kRatioSteps * kRatioStep + 0.15);
  Pairing best = pair_at_ratio(P, candidates, 0);
  bool foreshortened = false;
  for (int k = -kRatioSteps; k <= kRatioSteps; ++k) {
    if (k == 0) continue;
    Pairing p = pair_at_ratio(P, candidates, k * kRatioStep);
    if (p.elements.size() > best.elements.size() && p.elements.size() >= kMinForeshortenedElements)
      best = std::move(p), foreshortened = true;
  }
  if (foreshortened) {
    Pairing refined = pair_at_ratio(P, candidates, median_ln_ratio(P, best.elements));
    if (refined.elements.size() >= best.elements.size()) best = std::move(refined);
  }
  return best;
}

// Why patterns made no element, and what to do. All of one direction (a
// microscope frame whose lit disc shows one column's horizontal-bar
// triplets, their partners cut off: dev_13) says so, since bringing the
// other pattern into view, or cropping to one, is then the remedy.
std::string no_element_problem(const std::vector<BarPattern>& P) {
  if (P.empty())
    return "no USAF-1951 chart found: no three-bar pattern in the image (is the chart in view, in focus and lit?)";
  size_t along_x = 0;
  double widest_bar_px = 0;
  for (const BarPattern& p : P) {
    along_x += std::abs(p.bar_dir.x) >= std::abs(p.bar_dir.y);
    widest_bar_px = std::max(widest_bar_px, 0.5 * p.period_px);
  }
  const std::string what = fmt::format("no USAF-1951 chart found: {} three-bar pattern(s)", P.size());
  if (along_x == P.size() || along_x == 0) {
    // One pattern measured alone needs bars this wide (single_pattern_element).
    const std::string crop =
        widest_bar_px >= ChartDetection::kSinglePatternMinBarPx
            ? ", or crop the image to one pattern to measure it alone"
            : "";
    return fmt::format("{}, {} bars along the image's {} axis, and none with bars across them beside one of the "
                       "same size, as each element has (cut off, unlit, or blurred in that direction?): bring a whole "
                       "element into view{}",
                       what, P.size() == 1 ? "its" : "all with", along_x ? "x" : "y", crop);
  }
  return fmt::format("{} ({} with bars along the image's x axis, {} along y) but no element: no two of them are of "
                     "one size side by side, as an element's horizontal and vertical patterns are",
                     what, along_x, P.size() - along_x);
}

// Components by runs (chart_detect_internal.h). A few per cent of the
// pixels are marked: labelling every pixel (cv::connectedComponents) and
// then summing the moments over them cost 17 % of chart mode on a 1.5 Mpx
// frame, this pass a tenth of that. A component's root is its first run
// in raster order (union-find over run indices).
std::vector<int> run_components(const cv::Mat& mask, std::vector<MaskRun>& runs) {
  std::vector<int> parent;
  auto find = [&](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  size_t prev_begin = 0, prev_end = 0;
  for (int y = 0; y < mask.rows; ++y) {
    const unsigned char* m = mask.ptr<unsigned char>(y);
    const size_t row_begin = runs.size();
    for (int x = 0; x < mask.cols;) {
      if (x + 8 <= mask.cols) {
        // Eight mask bytes at once: none marked, or the first marked one
        // found from the word's zero bits before it (memory order is the
        // low bits first on a little-endian machine).
        std::uint64_t word;
        std::memcpy(&word, m + x, sizeof word);
        if (!word) {
          x += 8;
          continue;
        }
        x += (std::endian::native == std::endian::little ? std::countr_zero(word) : std::countl_zero(word)) / 8;
      } else if (!m[x]) {
        ++x;
        continue;
      }
      const int x0 = x;
      while (x < mask.cols && m[x]) ++x;
      runs.push_back({x0, x - 1, y});
      parent.push_back(static_cast<int>(parent.size()));
    }
    // Join each run to the previous row's runs it touches, diagonals
    // included; both rows' runs are in x order.
    size_t q0 = prev_begin;
    for (size_t r = row_begin; r < runs.size(); ++r) {
      while (q0 < prev_end && runs[q0].x1 < runs[r].x0 - 1) ++q0;
      for (size_t q = q0; q < prev_end && runs[q].x0 <= runs[r].x1 + 1; ++q) {
        const int a = find(static_cast<int>(q)), b = find(static_cast<int>(r));
        if (a != b) parent[std::max(a, b)] = std::min(a, b);
      }
    }
    prev_begin = row_begin;
    prev_end = runs.size();
  }
  for (size_t i = 0; i < parent.size(); ++i) parent[i] = find(static_cast<int>(i));
  return parent;
}

}  // namespace tactres::locate_detail
