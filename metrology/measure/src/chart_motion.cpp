#include "chart_motion.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/core.hpp>

namespace tactres::chart {

namespace {

constexpr int kMinAffineSamples = 8;
constexpr int kMinSimilaritySamples = 4;
// Singular values of the (centred, unit-scaled) design below this share of
// the largest leave some affine parameter to the noise: anchors along one
// line, or all across the same bars.
constexpr double kMinAffineConditioning = 1e-3;

// One least-squares solve in coordinates centred on the samples (`c0`),
// scaled by `scale_px` so that the columns are comparable.
struct Solved {
  bool ok = false;
  ChartMotion motion;
};

Solved solve(const std::vector<MotionSample>& s, Vec2 c0, double scale_px, bool affine) {
  const int n = static_cast<int>(s.size()), k = affine ? 6 : 4;
  cv::Mat A(n, k, CV_64F), b(n, 1, CV_64F);
  for (int i = 0; i < n; ++i) {
    const Vec2 c = (1.0 / scale_px) * (s[i].from_px - c0);
    const Vec2 u = s[i].across;
    double* row = A.ptr<double>(i);
    if (affine) {
      // n . (L c + t): L = [l0 l1; l2 l3]
      const double r[6] = {u.x * c.x, u.x * c.y, u.y * c.x, u.y * c.y, u.x, u.y};
      std::copy(r, r + 6, row);
    } else {
      // L = [a -b; b a]
      const double r[4] = {u.x * c.x + u.y * c.y, u.y * c.x - u.x * c.y, u.x, u.y};
      std::copy(r, r + 4, row);
    }
    b.at<double>(i) = s[i].across_px / scale_px;
  }
  cv::SVD svd(A, cv::SVD::NO_UV);
  const double w_max = svd.w.at<double>(0), w_min = svd.w.at<double>(k - 1);
  if (!(w_max > 0) || w_min < kMinAffineConditioning * w_max) return {};
  cv::Mat x;
  if (!cv::solve(A, b, x, cv::DECOMP_SVD)) return {};
  const double* p = x.ptr<double>();
  Solved out;
  out.ok = true;
  ChartMotion& m = out.motion;
  if (affine) {
    m.linear[0] = p[0], m.linear[1] = p[1], m.linear[2] = p[2], m.linear[3] = p[3];
    m.offset_px = scale_px * Vec2{p[4], p[5]};
  } else {
    m.linear[0] = p[0], m.linear[1] = -p[1], m.linear[2] = p[1], m.linear[3] = p[0];
    m.offset_px = scale_px * Vec2{p[2], p[3]};
  }
  // From centred coordinates back to pixels: M(p) = L (p - c0) + t.
  m.offset_px = m.offset_px - m.apply_linear(c0);
  return out;
}

double residual_px(const ChartMotion& m, const MotionSample& s) { return dot(s.across, m.apply(s.from_px)) - s.across_px; }

// The mean squared misfit of `now` against `reference` moved by `shift_mm`,
// after the best gain and offset; +inf when under 80 % of `now` overlaps.
double match_cost(const LevelProfile& now, const LevelProfile& reference, double shift_mm) {
  double n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0, syy = 0;
  size_t k = 1;  // reference segment [k-1, k]; `now` is in ascending u
  for (const auto& [u_mm, level] : now) {
    const double t = u_mm - shift_mm;
    if (t < reference.front().first || t > reference.back().first) continue;
    while (k + 1 < reference.size() && reference[k].first < t) ++k;
    const auto& [u0, v0] = reference[k - 1];
    const auto& [u1, v1] = reference[k];
    const double x = u1 > u0 ? v0 + (t - u0) / (u1 - u0) * (v1 - v0) : v0;
    n += 1, sx += x, sy += level, sxx += x * x, sxy += x * level, syy += level * level;
  }
  if (n < 0.8 * now.size() || n < 8) return std::numeric_limits<double>::infinity();
  const double vxx = sxx - sx * sx / n, vxy = sxy - sx * sy / n, vyy = syy - sy * sy / n;
  if (!(vxx > 0)) return std::numeric_limits<double>::infinity();
  return (vyy - vxy * vxy / vxx) / n;
}

}  // namespace

LevelProfile level_profile(const ProfileData& d) {
  LevelProfile out;
  for (int b = d.fit_begin; b < d.fit_end; ++b)
    if (d.count[b] > 0 && std::isfinite(d.value[b])) out.push_back({d.u_mean_mm[b], d.value[b]});
  return out;
}

std::optional<double> match_shift_mm(const LevelProfile& now, const LevelProfile& reference, double reach_mm) {
  if (now.size() < 8 || reference.size() < 8) return std::nullopt;
  // A grid over the reach, then a golden-section search in the best cell's
  // neighbourhood: the cost is continuous in the shift, not smooth enough
  // for Newton steps across bin boundaries.
  constexpr int kGridHalf = 12;
  const double h = reach_mm / kGridHalf;
  int best = 0;
  double best_cost = std::numeric_limits<double>::infinity();
  for (int i = -kGridHalf; i <= kGridHalf; ++i) {
    const double c = match_cost(now, reference, i * h);
    if (c < best_cost) best_cost = c, best = i;
  }
  if (!std::isfinite(best_cost) || std::abs(best) == kGridHalf) return std::nullopt;
  const double golden = 0.5 * (std::sqrt(5.0) - 1);
  double a = (best - 1) * h, b = (best + 1) * h;
  double x1 = b - golden * (b - a), x2 = a + golden * (b - a);
  double f1 = match_cost(now, reference, x1), f2 = match_cost(now, reference, x2);
  for (int it = 0; it < 30; ++it) {
    if (f1 < f2) {
      b = x2, x2 = x1, f2 = f1;
      x1 = b - golden * (b - a);
      f1 = match_cost(now, reference, x1);
    } else {
      a = x1, x1 = x2, f1 = f2;
      x2 = a + golden * (b - a);
      f2 = match_cost(now, reference, x2);
    }
  }
  return 0.5 * (a + b);
}

MotionFit fit_chart_motion(std::vector<MotionSample> samples, double outlier_px) {
  MotionFit fit;
  while (static_cast<int>(samples.size()) >= kMinSimilaritySamples) {
    Vec2 c0{0, 0};
    for (const MotionSample& s : samples) c0 = c0 + s.from_px;
    c0 = (1.0 / samples.size()) * c0;
    double scale_px = 0;
    for (const MotionSample& s : samples) scale_px = std::max(scale_px, norm(s.from_px - c0));
    scale_px = std::max(scale_px, 1.0);
    Solved sol;
    bool affine = static_cast<int>(samples.size()) >= kMinAffineSamples;
    if (affine) sol = solve(samples, c0, scale_px, true);
    if (!sol.ok) {
      affine = false;
      sol = solve(samples, c0, scale_px, false);
    }
    if (!sol.ok) return fit;
    size_t worst = 0;
    double worst_px = -1, sum2 = 0;
    for (size_t i = 0; i < samples.size(); ++i) {
      const double r = std::abs(residual_px(sol.motion, samples[i]));
      sum2 += r * r;
      if (r > worst_px) worst_px = r, worst = i;
    }
    if (worst_px > outlier_px) {
      samples.erase(samples.begin() + static_cast<long>(worst));
      continue;
    }
    fit.ok = true;
    fit.motion = sol.motion;
    fit.rms_px = std::sqrt(sum2 / samples.size());
    fit.samples_used = static_cast<int>(samples.size());
    fit.affine = affine;
    return fit;
  }
  return fit;
}

}  // namespace tactres::chart
