#include "tactres/profiles/profile_sampler.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <tuple>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "censored_level.h"

namespace tactres {

void ProfileSamplingOptions::validate() const {
  if (!(bin_px >= 0.05 && bin_px <= 1))
    throw std::invalid_argument("profile bin width must be in [0.05, 1] px");
  if (!(along_fraction > 0 && along_fraction <= 1))
    throw std::invalid_argument("along-bar fraction must be in (0, 1]");
  if (!(margin_bar_widths >= 0.5 && margin_bar_widths <= 5))
    throw std::invalid_argument("profile margin must be in [0.5, 5] bar widths");
  if (!(dense_bin_samples >= 16 && dense_bin_samples <= 1e6))
    throw std::invalid_argument("profile dense-bin sample count must be in [16, 1e6]");
}

Strip element_strip(const ElementLayout& e, const ProfileSamplingOptions& o) {
  const double w = e.bar_width_mm;
  Strip s;
  s.center_mm = e.extent_mm().center_mm();
  s.bars = e.orientation;
  s.half_u_mm = 2.5 * w + o.margin_bar_widths * w;
  s.half_v_mm = 0.5 * o.along_fraction * 5 * w;
  s.extend_u_mm = 4 * w;
  return s;
}

Strip patch_strip(const TargetLayout& layout, BarOrientation bars) {
  const RectMm& p = layout.reference_patch_mm;
  const bool u_is_width = bars == BarOrientation::vertical_bars;
  const double size_u = u_is_width ? p.width_mm() : p.height_mm();
  const double size_v = u_is_width ? p.height_mm() : p.width_mm();
  Strip s;
  s.center_mm = p.center_mm();
  s.bars = bars;
  s.half_u_mm = 0.5 * size_u + 0.15 * size_u;
  s.half_v_mm = 0.35 * size_v;
  s.extend_u_mm = 0.25 * size_u;
  return s;
}

namespace {

// Weighted least-squares line var = a + b * level (both clamped at 0): the
// photon-transfer relation of EMVA 1288 (read plus shot noise).
struct VarianceLine {
  double s_w = 0, s_x = 0, s_y = 0, s_xx = 0, s_xy = 0;
  void add(double w, double level, double var) {
    s_w += w;
    s_x += w * level;
    s_y += w * var;
    s_xx += w * level * level;
    s_xy += w * level * var;
  }
  std::pair<double, double> fit() const {
    double a = s_w > 0 ? s_y / s_w : 0.0, b = 0.0;
    const double det = s_w * s_xx - s_x * s_x;
    if (s_w > 0 && det > 1e-12 * s_w * s_xx) {
      b = std::max(0.0, (s_w * s_xy - s_x * s_y) / det);
      a = std::max(0.0, (s_y - b * s_x) / s_w);
    }
    return {a, b};
  }
};

bool u_along_x(const Strip& s) { return s.bars == BarOrientation::vertical_bars; }

Vec2 to_target(const Strip& s, double u, double v) {
  return u_along_x(s) ? Vec2{s.center_mm.x + u, s.center_mm.y + v} : Vec2{s.center_mm.x + v, s.center_mm.y + u};
}

// The map from pixel centres to strip coordinates (u, v) in mm: a cubic in
// the pixel coordinates, centred on the lattice's middle point and scaled
// to about +-1, fitted by least squares to the projected lattice through
// the normal equations (10 x 10, u and v at once; scaled, they are well
// conditioned). A quadratic left 0.04 px of error over the reference
// patch's strip through the example wide-angle lens; a cubic 0.001 px.
class PixelMap {
 public:
  PixelMap(const std::vector<Vec2>& px, const std::vector<Vec2>& uv) : center_px_(px[px.size() / 2]) {
    double scale_px = 1;
    for (const Vec2& q : px)
      scale_px = std::max({scale_px, std::abs(q.x - center_px_.x), std::abs(q.y - center_px_.y)});
    inv_scale_ = 1 / scale_px;
    const int n = static_cast<int>(px.size());
    cv::Mat A(n, kTerms, CV_64F), b(n, 2, CV_64F);
    for (int k = 0; k < n; ++k) {
      terms(px[k].x, px[k].y, A.ptr<double>(k));
      b.at<double>(k, 0) = uv[k].x;
      b.at<double>(k, 1) = uv[k].y;
    }
    cv::Mat coef;
    if (!cv::solve(A, b, coef, cv::DECOMP_CHOLESKY | cv::DECOMP_NORMAL))
      cv::solve(A, b, coef, cv::DECOMP_SVD);  // a lattice seen edge-on: the least-squares answer still
    // Plain arrays: cv::Mat's checked element access cost more than the map.
    for (int c = 0; c < kTerms; ++c) cu_[c] = coef.at<double>(c, 0), cv_[c] = coef.at<double>(c, 1);
  }

  Vec2 operator()(double x_px, double y_px) const {
    double r[kTerms];
    terms(x_px, y_px, r);
    double u = 0, v = 0;
    for (int c = 0; c < kTerms; ++c) {
      u += cu_[c] * r[c];
      v += cv_[c] * r[c];
    }
    return Vec2{u, v};
  }

 private:
  static constexpr int kTerms = 10;
  void terms(double x_px, double y_px, double* r) const {
    const double x = (x_px - center_px_.x) * inv_scale_, y = (y_px - center_px_.y) * inv_scale_;
    const double x2 = x * x, y2 = y * y;
    const double t[kTerms] = {1, x, y, x2, x * y, y2, x2 * x, x2 * y, x * y2, y2 * y};
    std::copy(t, t + kTerms, r);
  }
  Vec2 center_px_;
  double inv_scale_ = 1;
  double cu_[kTerms] = {}, cv_[kTerms] = {};
};

// The chain's blur is shift-invariant in pixels, not in target
// millimetres: through a distorting lens (or at a tilt) the image scale
// changes across a wide strip, and an edge's blur measured in u with it.
// The reference patch's two edges differed in width by ~2 % through the
// example wide-angle lens, a reduced chi^2 of 4-6 at 40 dB. Profiles are
// therefore binned in w, the distance from the strip's centre in pixels,
// divided by the centre's scale: w(u) = integral_0^u s(t) / s(0) dt, with
// the scale s across the bars along the centre line taken as the quadratic
// through its values at both ends and the centre. w = u to first order, so
// the fitted blur is the centre's, in millimetres there; with no change of
// scale (a pinhole seen face-on) w = u exactly.
struct ScaleWarp {
  double a_per_mm = 0, b_per_mm2 = 0;  // s(u) / s(0) = 1 + a u + b u^2
  double operator()(double u_mm) const { return u_mm + 0.5 * a_per_mm * u_mm * u_mm + b_per_mm2 * u_mm * u_mm * u_mm / 3; }
};

ScaleWarp scale_warp(const PlaneToImage& plane, const Strip& s, double u_end_mm, double scale_center) {
  const double lo = plane.px_per_mm_across(to_target(s, -u_end_mm, 0), s.bars);
  const double hi = plane.px_per_mm_across(to_target(s, u_end_mm, 0), s.bars);
  // Out of view or folded over: no warp rather than a wrong one.
  if (!(lo > 0.5 * scale_center && hi > 0.5 * scale_center && lo < 2 * scale_center && hi < 2 * scale_center))
    return {};
  return {(hi - lo) / (2 * u_end_mm * scale_center), (hi + lo - 2 * scale_center) / (2 * u_end_mm * u_end_mm * scale_center)};
}

// Ideal strip profile S(w) from every shape overlapping the extended strip.
std::vector<IdealBox> ideal_boxes(const IndexedArtwork& artwork, const Strip& s, double slice_mm, const ScaleWarp& warp) {
  const double U = s.half_u_mm + s.extend_u_mm, V = s.half_v_mm;
  const Vec2 a = to_target(s, -U, -V), b = to_target(s, U, V);
  const RectMm strip{std::min(a.x, b.x), std::min(a.y, b.y), std::max(a.x, b.x), std::max(a.y, b.y)};
  std::vector<int> hits;
  artwork.index().query(strip, hits);
  std::vector<IdealBox> boxes;
  for (int i : hits) {
    const ArtworkShape& shape = artwork.shapes()[i];
    const RectMm bounds = shape.bounds_mm();
    const double lo = u_along_x(s) ? bounds.x0 - s.center_mm.x : bounds.y0 - s.center_mm.y;
    const double hi = u_along_x(s) ? bounds.x1 - s.center_mm.x : bounds.y1 - s.center_mm.y;
    const double u0 = std::max(lo, -U), u1 = std::min(hi, U);
    if (!(u1 > u0)) continue;
    // Rectangles are one exact box; other shapes are sliced finely in u and
    // each slice's strip coverage is computed exactly.
    const int n = shape.kind == ArtworkShape::Kind::rect ? 1 : std::max(1, int(std::ceil((u1 - u0) / slice_mm)));
    for (int k = 0; k < n; ++k) {
      const double s0 = u0 + (u1 - u0) * k / n, s1 = u0 + (u1 - u0) * (k + 1) / n;
      const Vec2 p = to_target(s, s0, -V), q = to_target(s, s1, V);
      const RectMm slice{std::min(p.x, q.x), std::min(p.y, q.y), std::max(p.x, q.x), std::max(p.y, q.y)};
      const double level = intersection_area_mm2(shape, slice) / slice.area_mm2();
      if (level > 0) boxes.push_back({warp(s0), warp(s1), level});
    }
  }
  return boxes;
}

// Per-bin sums of the pixels' values and positions: the bin means, the
// within-bin spreads the noise models come from, and the moments of a plane
// in (u, v) per bin. u is w here (ScaleWarp).
struct BinSums {
  struct Bin {
    double sum = 0, sum2 = 0, sum_u = 0, sum_uu = 0;
    // Along-bar moments: the light varies along the bars too (vignetting,
    // illumination), which is not noise; the noise estimate removes it.
    double sum_v = 0, sum_vv = 0, sum_xv = 0;
    double sum_xu = 0, sum_uv = 0;  // for the per-bin plane in (u, v)
  };
  // One bin's sums side by side: every pixel adds to all nine, and nine
  // arrays cost a cache line each per pixel.
  std::vector<Bin> bins;
  explicit BinSums(int n) : bins(n) {}
  const Bin& operator[](int b) const { return bins[b]; }
  void add(int b, double value, double u, double v) {
    Bin& s = bins[b];
    s.sum += value;
    s.sum2 += value * value;
    s.sum_u += u;
    s.sum_uu += u * u;
    s.sum_v += v;
    s.sum_vv += v * v;
    s.sum_xv += value * v;
    s.sum_xu += value * u;
    s.sum_uv += u * v;
  }
};

struct Sample {
  double u_mm, v_mm, value;
  int bin;
};

struct PixelBox {
  int x0, y0, x1, y1;  // inclusive
};

// The pixels around the projected lattice, clipped to the image.
PixelBox pixel_box(const std::vector<Vec2>& px, int W, int H) {
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (const Vec2& q : px) {
    x0 = std::min(x0, q.x);
    y0 = std::min(y0, q.y);
    x1 = std::max(x1, q.x);
    y1 = std::max(y1, q.y);
  }
  return {std::max(0, int(std::floor(x0))), std::max(0, int(std::floor(y0))), std::min(W - 1, int(std::ceil(x1))),
          std::min(H - 1, int(std::ceil(y1)))};
}

// The row and column step at which a strip is read
// (ProfileSamplingOptions::dense_bin_samples): 1, or odd, so that every
// phase of a Bayer mosaic and of JPEG's 8 px blocks is read alike.
int pixel_stride(const std::array<Vec2, 4>& outline_px, int fit_bins, double bin_px, double dense_bin_samples) {
  std::vector<cv::Point2f> outline;
  for (const Vec2& q : outline_px) outline.emplace_back(static_cast<float>(q.x), static_cast<float>(q.y));
  const double per_bin = cv::contourArea(outline) / std::max(1, fit_bins);
  int k = 1;
  while (k + 2 <= bin_px && per_bin / ((k + 2) * (k + 2)) >= dense_bin_samples) k += 2;
  return k;
}

// Every finite pixel of `box` (every `stride`-th row and column) whose
// centre maps into the strip goes into its bin (in w) and into `samples`;
// masked and clipped pixels are counted in `out`.
void accumulate_pixels(const cv::Mat& lum, const PixelMap& map_uv, const ScaleWarp& warp, const PixelBox& box,
                       int stride, const Strip& s, double clip_level, BinSums& sums, std::vector<Sample>& samples,
                       std::vector<unsigned char>& clip_bits, SampledProfile& out) {
  ProfileData& d = out.data;
  const double U = s.half_u_mm, V = s.half_v_mm;
  samples.reserve(size_t(std::max(0, (box.x1 - box.x0) / stride + 1)) *
                  size_t(std::max(0, (box.y1 - box.y0) / stride + 1)));
  const double inv_bin = 1 / d.bin_mm;
  const float clip_at = static_cast<float>(clip_level * 0.9999);
  for (int y = box.y0; y <= box.y1; y += stride) {
    const float* row = lum.ptr<float>(y);
    // Along a row, u and v are cubics in x: stepped by forward differences
    // (the third is constant), taken from the map at the row's first four
    // pixels read; evaluating the map per pixel cost more than the rest of
    // the loop.
    const int x0 = box.x0, k = stride;
    const Vec2 p0 = map_uv(x0, y), p1 = map_uv(x0 + k, y), p2 = map_uv(x0 + 2 * k, y), p3 = map_uv(x0 + 3 * k, y);
    double u = p0.x, v = p0.y;
    double du = p1.x - p0.x, dv = p1.y - p0.y;
    double ddu = p2.x - 2 * p1.x + p0.x, ddv = p2.y - 2 * p1.y + p0.y;
    const double dddu = p3.x - 3 * p2.x + 3 * p1.x - p0.x, dddv = p3.y - 3 * p2.y + 3 * p1.y - p0.y;
    for (int x = x0; x <= box.x1; x += k, u += du, v += dv, du += ddu, dv += ddv, ddu += dddu, ddv += dddv) {
      if (std::abs(u) > U || std::abs(v) > V) continue;
      const double w = warp(u);  // binned in w (ScaleWarp)
      const float value = row[x];
      if (!std::isfinite(value)) {
        ++out.pixels_masked;
        continue;
      }
      const bool dark_clip = clip_level > 0 && value <= 0.f, bright_clip = clip_level > 0 && value >= clip_at;
      if (dark_clip || bright_clip) ++out.pixels_clipped;
      const int b = static_cast<int>(std::floor((w - d.u0_mm) * inv_bin));
      if (b < 0 || b >= d.bin_count) continue;
      // Bit 1: clipped at black, bit 2: at saturation (ProfileData::bound).
      if (dark_clip || bright_clip) clip_bits[b] |= dark_clip ? 1 : 2;
      sums.add(b, value, w, v);
      samples.push_back({w, v, value, b});
      ++d.count[b];
      ++out.pixels_used;
    }
  }
}

// Bin means and mean positions (empty bins: NaN at the bin centre), and the
// spread of the sample positions within the bins. Returns the mean |level|
// of the filled bins (1 if none).
double set_bin_means(ProfileData& d, const BinSums& sums, int pixels_used) {
  d.value.assign(d.bin_count, std::numeric_limits<double>::quiet_NaN());
  d.u_mean_mm.resize(d.bin_count);
  d.sigma.assign(d.bin_count, 1.0);
  double spread = 0, level = 0;
  int level_n = 0;
  for (int b = 0; b < d.bin_count; ++b) {
    d.u_mean_mm[b] = d.bin_center_mm(b);
    if (d.count[b] == 0) continue;
    d.value[b] = sums[b].sum / d.count[b];
    d.u_mean_mm[b] = sums[b].sum_u / d.count[b];
    spread += std::max(0.0, sums[b].sum_uu - sums[b].sum_u * sums[b].sum_u / d.count[b]);
    level += std::abs(d.value[b]);
    ++level_n;
  }
  d.bin_spread_var_mm2 = pixels_used > 0 ? spread / pixels_used : 0.0;
  return level_n ? level / level_n : 1.0;
}

// The filled bins (with at least 3 samples and a neighbour on both sides),
// flattest first: |change across the neighbours|, bin.
std::vector<std::pair<double, int>> flattest_first(const ProfileData& d, const std::vector<int>& filled) {
  std::vector<std::pair<double, int>> flatness;
  for (size_t k = 1; k + 1 < filled.size(); ++k)
    if (d.count[filled[k]] >= 3) flatness.push_back({std::abs(d.value[filled[k + 1]] - d.value[filled[k - 1]]), filled[k]});
  std::sort(flatness.begin(), flatness.end());
  return flatness;
}

// Light that varies along the bars (a hot spot, vignetting) is a relative
// gain 1 + g v over the strip. A bin's pixels need not be centred on
// v = 0: at a small roll the pixel rows fall into neighbouring bins in
// different bands of v, and their means would alternate by the gain
// difference, which no profile model describes. g is regressed from the
// pixels' departures from the profile P(u), interpolated between bin
// means: at a roll, u and v correlate within a bin, so a per-bin slope in
// u could not be told from the gain. Every bin mean is then referred to
// v = 0.
void refer_to_mid_strip(ProfileData& d, const BinSums& sums, const std::vector<Sample>& samples,
                        const std::vector<int>& filled, double half_v_mm) {
  std::vector<double> bin_v(d.bin_count, 0);
  for (int b : filled) bin_v[b] = sums[b].sum_v / d.count[b];
  // P(u) interpolated between the filled bins around u. A sample sits in
  // its own bin b, so its neighbours are b's previous and next filled bins
  // (looked up once per bin, not searched per sample).
  std::vector<int> prev_filled(d.bin_count, -1), next_filled(d.bin_count, -1);
  for (size_t k = 0; k < filled.size(); ++k) {
    if (k > 0) prev_filled[filled[k]] = filled[k - 1];
    if (k + 1 < filled.size()) next_filled[filled[k]] = filled[k + 1];
  }
  auto profile_at = [&](double u_mm, int b) {
    const int b0 = u_mm >= d.u_mean_mm[b] ? b : prev_filled[b];
    const int b1 = u_mm >= d.u_mean_mm[b] ? next_filled[b] : b;
    if (b0 < 0) return d.value[b1];
    if (b1 < 0) return d.value[b0];
    const double t = (u_mm - d.u_mean_mm[b0]) / (d.u_mean_mm[b1] - d.u_mean_mm[b0]);
    return d.value[b0] + t * (d.value[b1] - d.value[b0]);
  };
  // Per pixel: the regressor P dv and the departure value - P.
  std::vector<std::pair<double, double>> xy(samples.size());
  double num = 0, den = 0;
  for (size_t k = 0; k < samples.size(); ++k) {
    const Sample& q = samples[k];
    const double P = profile_at(q.u_mm, q.bin);
    xy[k] = {P * (q.v_mm - bin_v[q.bin]), q.value - P};
    num += xy[k].first * xy[k].second;
    den += xy[k].first * xy[k].first;
  }
  const double g_per_mm = den > 0 ? num / den : 0.0;
  // Applied only when it matters and is real: interpolating P(u) between
  // the bins of a fine element leaves errors that a spurious g would
  // otherwise absorb.
  double rss = 0;
  for (const auto& [x, y] : xy) rss += (y - g_per_mm * x) * (y - g_per_mm * x);
  const double g_sigma = den > 0 && samples.size() > 2 ? std::sqrt(rss / (samples.size() - 2) / den) : 0.0;
  const bool significant = std::abs(g_per_mm) > 4 * g_sigma && std::abs(g_per_mm) * half_v_mm > 2e-3;
  if (significant && std::abs(g_per_mm) * half_v_mm < 0.5)
    for (int b : filled) d.value[b] /= 1.0 + g_per_mm * sums[b].sum_v / d.count[b];
}

// Bins clipped at black only (clip bit 1) whose unclipped pixels still
// fix their level (censored_level.h): their value becomes that level and
// their clip bit is cleared, so that they are measurements, not bounds.
// Returns each such bin's standard error (0 elsewhere). A negative chart's
// dark ground at a few codes above black, under noise, clips in every bin
// (dev_02 with noise of 2 % of full scale: a quarter of its coarse
// patterns' pixels at 0): as bounds, no bin held the ground's level, and
// no level step could be measured.
std::vector<double> levels_past_black_clipping(ProfileData& d, const std::vector<Sample>& samples,
                                               std::vector<unsigned char>& clip_bits) {
  std::vector<double> sigma(d.bin_count, 0);
  std::vector<std::vector<double>> values(d.bin_count);
  for (const Sample& q : samples)
    if (clip_bits[q.bin] == 1) values[q.bin].push_back(q.value);
  for (int b = 0; b < d.bin_count; ++b) {
    if (clip_bits[b] != 1) continue;
    const std::optional<profiles_detail::CensoredLevel> level = profiles_detail::level_clipped_at_black(values[b]);
    if (!level) continue;
    d.value[b] = level->value;
    sigma[b] = level->sigma;
    clip_bits[b] = 0;
  }
  return sigma;
}

// Noise model var(level) = a + b * level (read noise plus shot noise, the
// photon-transfer relation of EMVA 1288), fitted to the within-bin
// variances of the flattest half of the bins (at an edge, a bin's width
// spans real signal change that is not noise), and the bins' sigmas from
// it, floored at 0.2 % of the level so that noise-free renders still weigh
// the bins sensibly. Dark bars are much quieter than bright ground under
// shot noise; one pooled variance would overstate the noise of the bars
// and understate it on the ground.
// Beside it, the detectability noise model (SampledProfile::noise_var_*)
// from the same bins: the residual after a plane in (u, v) per bin, so
// that the signal change across a bin's quarter pixel does not count as
// noise (it inflates the spread by ~12 % on simulated captures, where the
// noise is known).
void fit_noise_models(ProfileData& d, const BinSums& sums, const std::vector<std::pair<double, int>>& flatness,
                      double mean_abs_level, SampledProfile& out) {
  VarianceLine spread_line, residual_line;
  for (size_t k = 0; k < (flatness.size() + 1) / 2; ++k) {
    const int b = flatness[k].second;
    const double n = d.count[b];
    const double sxx = sums[b].sum2 - sums[b].sum * sums[b].sum / n;
    const double svv = sums[b].sum_vv - sums[b].sum_v * sums[b].sum_v / n;
    const double sxv = sums[b].sum_xv - sums[b].sum * sums[b].sum_v / n;
    // Residual sum of squares after a straight line in v.
    const double explained_v = svv > 0 ? sxv * sxv / svv : 0.0;
    spread_line.add(n - 2, d.value[b], std::max(0.0, sxx - explained_v) / (n - 2));
    if (n < 5) continue;
    // After a plane in (u, v): RSS = Sxx - c^T M^-1 c, M the (u, v) scatter, c = (Sxu, Sxv).
    const double suu = sums[b].sum_uu - sums[b].sum_u * sums[b].sum_u / n;
    const double suv = sums[b].sum_uv - sums[b].sum_u * sums[b].sum_v / n;
    const double sxu = sums[b].sum_xu - sums[b].sum * sums[b].sum_u / n;
    const double det = suu * svv - suv * suv;
    const double explained_uv = det > 1e-12 * (suu * svv + 1e-300)
                                    ? (svv * sxu * sxu - 2 * suv * sxu * sxv + suu * sxv * sxv) / det
                                    : explained_v;
    residual_line.add(n - 3, d.value[b], std::max(0.0, sxx - explained_uv) / (n - 3));
  }
  const auto [a, slope] = spread_line.fit();
  std::tie(out.noise_var_offset, out.noise_var_per_level) = residual_line.fit();
  out.noise_dof = residual_line.s_w;
  const double floor_sd = 2e-3 * mean_abs_level;
  const double mean_level = spread_line.s_w > 0 ? spread_line.s_x / spread_line.s_w : 0.0;
  out.noise_sd = std::sqrt(std::max(0.0, a + slope * mean_level));
  for (int b = 0; b < d.bin_count; ++b)
    if (d.count[b] > 0) {
      const double var = std::max(a + slope * std::max(0.0, d.value[b]), floor_sd * floor_sd);
      d.sigma[b] = std::sqrt(var / d.count[b]);
    }
}

}  // namespace

SampledProfile sample_strip(const cv::Mat& lum, const PlaneToImage& plane, const IndexedArtwork& artwork,
                            const Strip& s, const ProfileSamplingOptions& o, double clip_level) {
  SampledProfile out;
  const int W = lum.cols, H = lum.rows;
  const double U = s.half_u_mm, V = s.half_v_mm;

  // Project a 7 x 7 lattice over the strip: outline, scale, and the data for
  // the local pixel -> (u, v) map (PixelMap).
  const int n = 7;
  std::vector<Vec2> px, uv;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double u = -U + 2 * U * i / (n - 1), v = -V + 2 * V * j / (n - 1);
      const auto q = plane.project(to_target(s, u, v));
      if (!q || q->x < 0 || q->y < 0 || q->x > W - 1 || q->y > H - 1) return out;  // out of view
      px.push_back(*q);
      uv.push_back({u, v});
    }
  out.in_view = true;
  out.outline_px = {px[0], px[n - 1], px[n * n - 1], px[n * (n - 1)]};
  out.px_per_mm_across = plane.px_per_mm_across(s.center_mm, s.bars);
  out.px_per_mm_along = plane.px_per_mm_across(
      s.center_mm, s.bars == BarOrientation::vertical_bars ? BarOrientation::horizontal_bars : BarOrientation::vertical_bars);
  if (!(out.px_per_mm_across > 0)) {
    out.in_view = false;
    return out;
  }

  const PixelMap map_uv(px, uv);
  for (int k = 0; k < n * n; ++k)
    out.map_error_px = std::max(out.map_error_px, norm(map_uv(px[k].x, px[k].y) - uv[k]) * out.px_per_mm_across);

  // Bins over the extended range.
  ProfileData& d = out.data;
  d.bin_mm = o.bin_px / out.px_per_mm_across;
  const double Uext = U + s.extend_u_mm;
  // An even count, so that a bin edge always sits at the strip centre: with
  // an odd count the whole grid moved by half a bin, and a last-bit change
  // of the image scale that tipped the count moved every m by up to ~1 %.
  const ScaleWarp warp = scale_warp(plane, s, Uext, out.px_per_mm_across);
  const double Wext = std::max(-warp(-Uext), warp(Uext));
  d.bin_count = 2 * std::max(4, static_cast<int>(std::ceil(Wext / d.bin_mm)));
  d.u0_mm = -0.5 * d.bin_count * d.bin_mm;
  d.fit_begin = std::max(0, static_cast<int>(std::floor((warp(-U) - d.u0_mm) / d.bin_mm)));
  d.fit_end = std::min(d.bin_count, static_cast<int>(std::ceil((warp(U) - d.u0_mm) / d.bin_mm)));
  d.count.assign(d.bin_count, 0);
  BinSums sums(d.bin_count);
  std::vector<Sample> samples;  // kept for the along-bar light correction
  std::vector<unsigned char> clip_bits(d.bin_count, 0);
  const int stride = pixel_stride(out.outline_px, d.fit_end - d.fit_begin, o.bin_px, o.dense_bin_samples);
  accumulate_pixels(lum, map_uv, warp, pixel_box(px, W, H), stride, s, clip_level, sums, samples, clip_bits, out);
  const double mean_abs_level = set_bin_means(d, sums, out.pixels_used);
  std::vector<int> filled;  // bins holding samples (aligned pixels leave gaps)
  for (int b = 0; b < d.bin_count; ++b)
    if (d.count[b] > 0) filled.push_back(b);
  // A clipped bin's spread is not its noise: only bins with no clipped
  // pixel enter the noise model.
  std::vector<int> measured;
  for (int b : filled)
    if (clip_bits[b] == 0) measured.push_back(b);
  const std::vector<double> censored_sigma =
      out.pixels_clipped > 0 ? levels_past_black_clipping(d, samples, clip_bits) : std::vector<double>();
  refer_to_mid_strip(d, sums, samples, filled, V);
  if (out.pixels_clipped > 0) {
    static constexpr signed char kBoundOf[4] = {0, -1, 1, 2};
    d.bound.resize(d.bin_count);
    for (int b = 0; b < d.bin_count; ++b) d.bound[b] = kBoundOf[clip_bits[b]];
  }
  fit_noise_models(d, sums, flattest_first(d, measured), mean_abs_level, out);
  // A censored bin's error is its own, or the noise model's where larger.
  for (int b = 0; b < static_cast<int>(censored_sigma.size()); ++b)
    d.sigma[b] = std::max(d.sigma[b], censored_sigma[b]);
  d.ideal = ideal_boxes(artwork, s, 0.25 * d.bin_mm, warp);
  return out;
}

double SampledProfile::noise_sd_at(double level) const {
  return std::sqrt(std::max(0.0, noise_var_offset + noise_var_per_level * std::max(0.0, level)));
}

bool is_complement_box(const ProfileData& d, const IdealBox& b) {
  return b.level == 1.0 && b.u0_mm <= d.u0_mm && b.u1_mm >= d.u0_mm + d.bin_count * d.bin_mm;
}

void complement_ideal(ProfileData& d) {
  for (IdealBox& b : d.ideal) b.level = -b.level;
  d.ideal.push_back({d.u0_mm, d.u0_mm + d.bin_count * d.bin_mm, 1.0});
}

}  // namespace tactres
