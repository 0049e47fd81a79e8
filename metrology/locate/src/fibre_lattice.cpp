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
// A coarser lattice's first ring is not looked for (nor the power of a
// chart's large bars taken for one: dev_02's at 32 px).
constexpr double kMaxHarmonicPitchPx = 20;
constexpr int kRingSideBins = 6;
constexpr double kPeakRadiusBins = 2;       // a ring is compared with the radii this far in and out
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

// The spectrum's power by whole radius: the mean log power (a ring's
// geometric mean), the values (for the median) and the strongest bin.
struct Rings {
  std::vector<double> log_sum;
  std::vector<std::vector<float>> values;
  std::vector<Peak> strongest;

  explicit Rings(const Spectrum& s) : log_sum(kCropPx / 2 + 1, 0), values(kCropPx / 2 + 1), strongest(kCropPx / 2 + 1) {
    const int n = kCropPx;
    for (int v = -n / 2; v < n / 2; ++v)
      for (int u = -n / 2; u < n / 2; ++u) {
        const int r = static_cast<int>(std::lround(std::hypot(u, v)));
        if (r > n / 2) continue;
        log_sum[r] += std::log(s.at(u, v) + 1e-30);
        values[r].push_back(s.at(u, v));
        if (s.at(u, v) > strongest[r].power) strongest[r] = {u, v, s.at(u, v)};
      }
  }
  double log_mean(int r) const { return log_sum[r] / static_cast<double>(values[r].size()); }
  double median(int r) const {
    std::vector<float> v = values[r];
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return std::max<double>(v[v.size() / 2], 1e-30);
  }
};

// Three peaks of a hexagonal lattice about radius r: the strongest bin
// within a bin of r, and bins as strong turned by 60 and 120 degrees at
// its radius (within 6 %, or kPeakRadiusBins on small rings: the bins'
// own steps, and a bundle's domains turned against each other, spread
// them), each kMinPeakToMedian times the median power at r or more.
struct HexPeaks {
  double mean_radius = 0;  // of the three peaks (finer than a bin)
  double weakest_power = 0;
};
std::optional<HexPeaks> hexagonal_peaks(const Spectrum& s, const Rings& rings, int r) {
  if (r < 2 || r + 1 > kCropPx / 2) return std::nullopt;
  Peak first = rings.strongest[static_cast<size_t>(r)];
  for (const int q : {r - 1, r + 1})
    if (rings.strongest[static_cast<size_t>(q)].power > first.power) first = rings.strongest[static_cast<size_t>(q)];
  const double threshold = kMinPeakToMedian * rings.median(r), first_r = std::hypot(first.u, first.v);
  if (first.power < threshold) return std::nullopt;
  HexPeaks h{first_r, first.power};
  for (const double turn_deg : {60.0, 120.0}) {
    const double a = turn_deg * std::numbers::pi / 180;
    const Peak p = strongest_near(s, first.u * std::cos(a) - first.v * std::sin(a),
                                  first.u * std::sin(a) + first.v * std::cos(a), 3);
    const double p_r = std::hypot(p.u, p.v);
    if (p.power < threshold || std::abs(p_r - first_r) > std::max(0.06 * first_r, kPeakRadiusBins))
      return std::nullopt;
    h.mean_radius += p_r;
    h.weakest_power = std::min<double>(h.weakest_power, p.power);
  }
  h.mean_radius /= 3;
  return h;
}

// Whether radius r stands where a hexagonal lattice of first radius r1
// rings beyond its first: at sqrt(a^2 + ab + b^2) times r1 for whole a, b
// (sqrt(3), 2, sqrt(7), 3, sqrt(12), sqrt(13), ...), within 3 %.
bool is_shell_of(double r, double r1) {
  const double k = (r / r1) * (r / r1);
  for (int a = 1; a * a <= k * 1.07; ++a)
    for (int b = 0; b <= a; ++b) {
      const int norm = a * a + a * b + b * b;
      if (norm > 1 && std::abs(std::sqrt(k / norm) - 1) < 0.03) return true;
    }
  return false;
}

}  // namespace

std::optional<double> fibre_lattice_pitch_px(const cv::Mat& img) {
  if (std::min(img.cols, img.rows) < kCropPx) return std::nullopt;
  const Spectrum s = centre_spectrum(img);
  const Rings rings(s);
  const int n = kCropPx;
  const int r_min = static_cast<int>(std::ceil(n / kMaxPitchPx)), r_max = static_cast<int>(n / kMinPitchPx);
  const auto ring_excess = [&](int r) {  // log of the geometric-mean excess over the radii beside it
    return rings.log_mean(r) - 0.5 * (rings.log_mean(r - kRingSideBins) + rings.log_mean(r + kRingSideBins));
  };
  int ring = -1;
  double excess = 0;
  for (int r = r_min; r <= std::min(r_max, n / 2 - kRingSideBins); ++r)
    if (const double e = ring_excess(r); e > excess) excess = e, ring = r;
  if (ring < 0 || excess < std::log(kMinRingExcess)) return std::nullopt;
  const std::optional<HexPeaks> found = hexagonal_peaks(s, rings, ring);
  if (!found) return std::nullopt;
  // A hexagonal lattice also rings at sqrt(3), 2, sqrt(7), 3, ... times
  // its first radius, and for a coarse lattice one of those can stand out
  // more than the first: the first is the smallest radius that rings too,
  // with three peaks 60 degrees apart, each as strong as the found ring's
  // weakest. Round cores pass less power the finer the ring; bars and
  // their beat with the cores, which show peaks too, are far weaker than a
  // lattice over the whole square, and the found ring must be one of its
  // shells. A lattice
  // with rows kMaxPitchPx to kMaxHarmonicPitchPx apart then gives none,
  // not a harmonic's pitch (rows still further apart are not looked for).
  double radius = found->mean_radius;
  const int r_floor = static_cast<int>(std::ceil(n / kMaxHarmonicPitchPx));
  for (int r = r_floor; r < std::lround(found->mean_radius / std::sqrt(3.0) * 1.06); ++r) {
    const std::optional<HexPeaks> first = hexagonal_peaks(s, rings, r);
    if (first && first->weakest_power >= found->weakest_power && ring_excess(r) >= std::log(kMinRingExcess) &&
        is_shell_of(found->mean_radius, first->mean_radius)) {
      radius = first->mean_radius;
      break;
    }
  }
  const double pitch_px = n / radius;  // the rows' pitch: their frequency is the first ring's radius
  if (pitch_px > kMaxPitchPx) return std::nullopt;
  return pitch_px;
}

}  // namespace tactres::locate_detail
