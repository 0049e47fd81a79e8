// Where the image departs from its ground, at one detection scale: a
// background-normalised log image for inked discs (normalise) and a mask of
// significant edges for a relief's rims and crescents (relief_mask).

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "fiducials_internal.h"

namespace tactres::locate_detail {

Workspace& workspace() {
  thread_local Workspace w;
  return w;
}

namespace {

std::vector<float> sample_pixels(const cv::Mat& m, int target_count) {
  const double step = std::max(1.0, std::sqrt(double(m.total()) / target_count));
  std::vector<float> v;
  v.reserve(target_count + m.rows + m.cols);
  for (double y = 0.5 * step; y < m.rows; y += step) {
    const float* row = m.ptr<float>(static_cast<int>(y));
    for (double x = 0.5 * step; x < m.cols; x += step) v.push_back(row[static_cast<int>(x)]);
  }
  return v;
}

}  // namespace

Normalised normalise(const cv::Mat& img) {
  Normalised out;
  std::vector<float> s = sample_pixels(img, 5000);
  const double lo = percentile_of(s, 0.005), hi = percentile_of(s, 0.995);
  if (!(hi - lo > 1e-12 * std::max(1.0, std::abs(hi)))) return out;  // blank image
  // Log of luminance minus its local (geometric) mean: multiplicative
  // illumination gradients and vignetting cancel, and both polarities are
  // symmetric around 0. The offset keeps a dark ground's noise from exploding.
  const float base = static_cast<float>(std::min(lo, 0.0));
  const float eps = static_cast<float>(0.01 * (hi - base));
  // One buffer, transformed in place (see Workspace).
  Workspace& ws = workspace();
  cv::Mat& L = ws.log_img;
  L.create(img.size(), CV_32F);
  for (int y = 0; y < img.rows; ++y) {
    const float* src = img.ptr<float>(y);
    float* dst = L.ptr<float>(y);
    for (int x = 0; x < img.cols; ++x) dst[x] = std::max(src[x] - base, 0.0f) + eps;
  }
  cv::log(L, L);
  // The box must be several disc diameters wide: a disc of a target that
  // fills the image is ~6 % of its height across.
  int k = static_cast<int>(0.2 * std::min(img.cols, img.rows)) | 1;
  k = std::max(k, 15);
  cv::Mat& B = ws.log_mean;
  cv::blur(L, B, cv::Size(k, k), cv::Point(-1, -1), cv::BORDER_REFLECT);
  cv::subtract(L, B, L);
  out.n = L;
  std::vector<float> an = sample_pixels(out.n, 5000);
  for (float& x : an) x = std::abs(x);
  out.sn = std::max(percentile_of(an, 0.998), 0.05);
  out.noise = 1.4826 * percentile_of(an, 0.5);  // most pixels are ground
  out.n.convertTo(ws.n8, CV_8U, 127.5 / out.sn, 127.5);
  out.n8 = ws.n8;
  // Nothing stands out of the noise (a blank or defocused view): thresholds
  // would only cut the noise into countless specks.
  if (out.sn < 6 * out.noise) return out;
  out.otsu =
      cv::threshold(out.n8, ws.otsu_scratch, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
  out.blank = false;
  return out;
}

namespace {

// A smooth background at ~4 px: the mean over 4x4 blocks, a 3x3 box on
// that grid, bilinear back up (~4 px Gaussian overall, and ~3x cheaper than
// two 9x9 boxes at full size). `small` receives the block grid.
void smooth_background(const cv::Mat& img, cv::Mat& small, cv::Mat& bg) {
  const cv::Size s((img.cols + 3) / 4, (img.rows + 3) / 4);
  cv::resize(img, small, s, 0, 0, cv::INTER_AREA);
  cv::blur(small, small, cv::Size(3, 3), cv::Point(-1, -1), cv::BORDER_REFLECT);
  cv::resize(small, bg, img.size(), 0, 0, cv::INTER_LINEAR);
}

// The photon-transfer model of the noise: var = var_a + var_b level (read
// noise, shot noise), in input units.
struct NoiseModel {
  double var_a = 0, var_b = 0;
};

// Noise versus background level, from a sample: binned by level (the
// background's range [lo, hi]), and in each bin a low quantile of
// |fine - bg| (most pixels are flat ground; edges sit in the upper tail).
// q25 of |N(0, s)| is 0.3186 s. nullopt when no bin holds enough pixels.
std::optional<NoiseModel> fit_noise_model(const cv::Mat& fine, const cv::Mat& bg, double lo,
                                          double hi) {
  constexpr int kBins = 16;
  std::array<std::vector<float>, kBins> bins;
  std::array<double, kBins> level_sum{};
  {
    const int step = std::max(1, static_cast<int>(std::sqrt(double(bg.total()) / 8000)));
    for (int y = step / 2; y < bg.rows; y += step) {
      const float* pb = bg.ptr<float>(y);
      const float* pf = fine.ptr<float>(y);
      for (int x = step / 2; x < bg.cols; x += step) {
        const int k = std::clamp(static_cast<int>((pb[x] - lo) / (hi - lo) * kBins), 0, kBins - 1);
        bins[k].push_back(std::abs(pf[x] - pb[x]));
        level_sum[k] += pb[x];
      }
    }
  }
  // Fitted to the bins weighted by their pixel counts: a bin made mostly of
  // edges (a level that only occurs beside strong edges, as in a uniformly
  // lit capture) then cannot raise the threshold at its level.
  size_t total = 0;
  for (const auto& bin : bins) total += bin.size();
  double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (int k = 0; k < kBins; ++k) {
    if (bins[k].size() < std::max<size_t>(40, total / 50)) continue;
    const double w = bins[k].size(), x = level_sum[k] / bins[k].size();
    const double sd = percentile_of(bins[k], 0.25) / 0.3186;
    sw += w;
    sx += w * x;
    sy += w * sd * sd;
    sxx += w * x * x;
    sxy += w * x * sd * sd;
  }
  if (!(sw > 0)) return std::nullopt;
  NoiseModel m;
  m.var_b = (sw * sxy - sx * sy) / std::max(sw * sxx - sx * sx, 1e-300);
  m.var_a = (sy - m.var_b * sx) / sw;
  if (!(m.var_b > 0)) {
    m.var_b = 0;
    m.var_a = sy / sw;
  } else if (m.var_a < 0) {
    m.var_a = 0;
    m.var_b = sxy / std::max(sxx, 1e-300);
  }
  return m;
}

// Threshold per background level into `thr` (image size): 4 sigma of the
// noise, and never below 2 % of the level (a noise-free render has no noise
// to set the threshold, only numerical ripple) nor 0.1 % of the range.
// Evaluated on the block grid `small` and brought up like the background
// (it is as smooth).
void threshold_map(const NoiseModel& noise, const cv::Mat& small, double lo, double hi,
                   cv::Size size, cv::Mat& thr_small, cv::Mat& thr) {
  constexpr double kSigmas = 4.0, kMinContrast = 0.02;
  const double floor_abs = 1e-3 * (std::abs(hi) + std::abs(lo));
  auto threshold_at = [&](double g) {
    const double sd = std::sqrt(std::max(0.0, noise.var_a + noise.var_b * g));
    return std::max({kSigmas * sd, kMinContrast * std::abs(g), floor_abs});
  };
  thr_small.create(small.size(), CV_32F);
  for (int y = 0; y < small.rows; ++y) {
    const float* p = small.ptr<float>(y);
    float* q = thr_small.ptr<float>(y);
    for (int x = 0; x < small.cols; ++x) q[x] = static_cast<float>(threshold_at(p[x]));
  }
  cv::resize(thr_small, thr, size, 0, 0, cv::INTER_LINEAR);
}

// The significant deviations of `fine` from a background taken without
// them, into ws.relief. A strong edge raises the background around it (by
// up to ~1/4 of its peak), so the deviation shows side lobes of the other
// sign up to ~8 px either side, which pass the threshold too: a disc's
// outline would grow by several pixels and merge with specks around it. So
// the significant pixels (and their neighbours) are replaced by the
// background and the background is taken again: the lobes drop ~4x, and a
// linear illumination ramp is left as it was.
void significant_without_lobes(const cv::Mat& img, Workspace& ws) {
  cv::Mat &fine = ws.fine, &bg = ws.bg, &small = ws.small, &thr = ws.thr;
  cv::Mat &mag = ws.mag, &edges = ws.edges, &patched = ws.patched;
  cv::absdiff(fine, bg, mag);
  cv::compare(mag, thr, edges, cv::CMP_GT);
  cv::dilate(edges, edges, cv::Mat());  // 3x3
  img.copyTo(patched);
  bg.copyTo(patched, edges);
  smooth_background(patched, small, bg);
  cv::absdiff(fine, bg, mag);
  // What remains of the lobes (a few % of the edge's peak) can still pass
  // the noise threshold beside a strong edge: pixels below 15 % of the
  // strongest deviation within the background's reach (8 px) are left out.
  // (A disc's rim loses only where it runs within ~10 degrees of the light.)
  cv::Mat& local_max = patched;  // reused
  cv::dilate(mag, local_max, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(17, 17)));
  local_max *= 0.15;
  cv::max(thr, local_max, thr);
  cv::compare(mag, thr, ws.relief, cv::CMP_GT);
}

}  // namespace

// Where a relief seen through a gel shows its edges. Under a directional
// light (linearised Lambert) the image is proportional to the surface slope
// along the light, so a raised disc shows only a thin light and a thin dark
// crescent on a ground that a strongly non-uniform illumination (diffuser
// spot, vignetting, hot spots) makes vary far more than the crescents do.
// A global normalisation (normalise() above) cannot threshold that: its
// noise is that of the darkest corners. Here the deviation from a local
// background (a band-pass: edges ~1-3 px wide pass, illumination does not)
// is tested against the noise expected AT THAT BACKGROUND LEVEL, measured
// from the image itself (shot noise grows with the level, read noise does
// not). Both signs count: light and dark crescents alike, and rings.
ReliefMask relief_mask(const cv::Mat& img) {
  ReliefMask out;
  if (std::min(img.cols, img.rows) < 16) return out;
  // Slight smoothing (3x3 binomial), about the width of a blurred edge's
  // slope: it halves the noise and keeps the crescents. The background is
  // wide against a crescent, narrow against any illumination feature.
  Workspace& ws = workspace();
  cv::Mat &fine = ws.fine, &bg = ws.bg, &small = ws.small;
  cv::GaussianBlur(img, fine, cv::Size(3, 3), 0, 0, cv::BORDER_REFLECT);
  smooth_background(img, small, bg);

  double lo = kInf, hi = -kInf;
  for (int y = 0; y < small.rows; ++y) {
    const float* p = small.ptr<float>(y);
    for (int x = 0; x < small.cols; ++x) {
      lo = std::min(lo, double(p[x]));
      hi = std::max(hi, double(p[x]));
    }
  }
  if (!(hi - lo > 1e-12 * std::max(1.0, std::abs(hi)))) return out;  // blank image
  const std::optional<NoiseModel> noise = fit_noise_model(fine, bg, lo, hi);
  if (!noise) return out;
  threshold_map(*noise, small, lo, hi, img.size(), ws.thr_small, ws.thr);
  significant_without_lobes(img, ws);
  out.mask = ws.relief;
  out.blank = false;
  return out;
}

}  // namespace tactres::locate_detail
