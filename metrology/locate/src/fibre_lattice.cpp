// fibre_lattice_pitch_px (chart_detect_internal.h): a coherent fibre
// bundle's honeycomb, found in the spectrum of the image's centre.

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "chart_detect_internal.h"

namespace tactres::locate_detail {

namespace {

constexpr int kCropPx = 256;           // the centred square the spectrum is taken of
constexpr double kMinPitchPx = 3.0;    // finer, the lattice is the sensor's business
constexpr double kMaxPitchPx = 10.0;   // coarser, its cores are as wide as fine bars
constexpr int kRingSideBins = 6;       // a ring is compared with the radii this far in and out
// The lattice's ring of power stands above the radii beside it by this
// factor in the geometric mean (dev_01 10.7, dev_02 3.1; the 14 other real
// captures 1.3-1.8: bars and noise make no ring).
constexpr double kMinRingExcess = 2.4;
// Each of the three peaks 60 degrees apart stands this many times above
// the median power at its radius (dev_01: 7-22, dev_02: 7-14).
constexpr double kMinPeakToMedian = 5;

struct Spectrum {
  cv::Mat power;  // CV_32F, kCropPx square, DC at (0, 0)
  float at(int u, int v) const { return power.at<float>((v + kCropPx) % kCropPx, (u + kCropPx) % kCropPx); }
};

Spectrum centre_spectrum(const cv::Mat& img) {
  const cv::Rect crop((img.cols - kCropPx) / 2, (img.rows - kCropPx) / 2, kCropPx, kCropPx);
  cv::Mat patch, window, complex;
  img(crop).convertTo(patch, CV_32F);
  patch -= cv::mean(patch)[0];
  cv::createHanningWindow(window, patch.size(), CV_32F);
  cv::dft(patch.mul(window), complex, cv::DFT_COMPLEX_OUTPUT);
  cv::Mat planes[2];
  cv::split(complex, planes);
  Spectrum s;
  cv::magnitude(planes[0], planes[1], s.power);
  s.power = s.power.mul(s.power);
  return s;
}

// The strongest bin within `reach` bins of (u, v) and its power.
struct Peak {
  int u = 0, v = 0;
  float power = -1;
};
Peak strongest_near(const Spectrum& s, double u0, double v0, int reach) {
  Peak best;
  for (int dv = -reach; dv <= reach; ++dv)
    for (int du = -reach; du <= reach; ++du) {
      const int u = static_cast<int>(std::lround(u0)) + du, v = static_cast<int>(std::lround(v0)) + dv;
      if (std::abs(u) >= kCropPx / 2 || std::abs(v) >= kCropPx / 2) continue;
      if (s.at(u, v) > best.power) best = {u, v, s.at(u, v)};
    }
  return best;
}

}  // namespace

std::optional<double> fibre_lattice_pitch_px(const cv::Mat& img) {
  if (std::min(img.cols, img.rows) < kCropPx) return std::nullopt;
  const Spectrum s = centre_spectrum(img);
  const int n = kCropPx;
  const int r_min = static_cast<int>(std::ceil(n / kMaxPitchPx)), r_max = static_cast<int>(n / kMinPitchPx);
  // Log power by whole radius: its mean (the ring's geometric mean) and
  // the values (for the median), and the strongest bin of each.
  std::vector<double> log_sum(n / 2 + 1, 0);
  std::vector<std::vector<float>> values(n / 2 + 1);
  std::vector<Peak> strongest(n / 2 + 1);
  for (int v = -n / 2; v < n / 2; ++v)
    for (int u = -n / 2; u < n / 2; ++u) {
      const int r = static_cast<int>(std::lround(std::hypot(u, v)));
      if (r > n / 2) continue;
      log_sum[r] += std::log(s.at(u, v) + 1e-30);
      values[r].push_back(s.at(u, v));
      if (s.at(u, v) > strongest[r].power) strongest[r] = {u, v, s.at(u, v)};
    }
  auto log_mean = [&](int r) { return log_sum[r] / static_cast<double>(values[r].size()); };
  int ring = -1;
  double excess = 0;
  for (int r = r_min; r <= std::min(r_max, n / 2 - kRingSideBins); ++r) {
    const double e = log_mean(r) - 0.5 * (log_mean(r - kRingSideBins) + log_mean(r + kRingSideBins));
    if (e > excess) excess = e, ring = r;
  }
  if (ring < 0 || excess < std::log(kMinRingExcess)) return std::nullopt;
  // A hexagonal lattice: the ring's strongest peak, and peaks as strong at
  // its radius (within 6 %) turned by 60 and 120 degrees.
  const Peak first = strongest[static_cast<size_t>(ring)];
  std::vector<float>& at_ring = values[static_cast<size_t>(ring)];
  std::nth_element(at_ring.begin(), at_ring.begin() + at_ring.size() / 2, at_ring.end());
  const double median = std::max<double>(at_ring[at_ring.size() / 2], 1e-30);
  for (const double turn_deg : {60.0, 120.0}) {
    const double a = turn_deg * std::numbers::pi / 180;
    const Peak p = strongest_near(s, first.u * std::cos(a) - first.v * std::sin(a),
                                  first.u * std::sin(a) + first.v * std::cos(a), 3);
    if (p.power < kMinPeakToMedian * median || std::abs(std::hypot(p.u, p.v) / ring - 1) > 0.06) return std::nullopt;
  }
  if (first.power < kMinPeakToMedian * median) return std::nullopt;
  return static_cast<double>(n) / ring;  // the rows' pitch: their frequency is the ring's radius
}

}  // namespace tactres::locate_detail
