// EMVA 1288 linear camera model (EMVA Standard 1288, Release 4.0 Linear).
//
// Poisson sampling: W. Hoermann, "The transformed rejection method for
// generating Poisson random variables", Insurance: Mathematics and Economics
// 12 (1993) 39-45 (algorithm PTRS) for means >= 10; Knuth's product of
// uniforms (TAOCP vol. 2, 3.4.1) below. Gaussian: Box-Muller (1958).
// Both are written out here so that the noise is a function of the seed
// alone, whatever standard library the program is built with.

#include "tactres/simulate/effects/sensor_model.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "tactres/util/rng.h"

namespace tactres {

namespace {

bool finite_in(double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; }

// log(k!) without std::lgamma, which writes the global `signgam` in glibc
// (a data race across the row threads). Exact table below 16, Stirling's
// series above (truncation error < 1 / (1680 x^7) < 1e-11 for x >= 17).
double log_factorial(double k) {
  static const std::array<double, 16> table = [] {
    std::array<double, 16> t{};
    double acc = 0.0;
    for (int i = 1; i < 16; ++i) {
      acc += std::log(static_cast<double>(i));
      t[i] = acc;
    }
    return t;
  }();
  if (k < 16.0) return table[static_cast<std::size_t>(k)];
  const double x = k + 1.0;
  const double ix = 1.0 / x, ix2 = ix * ix;
  return (x - 0.5) * std::log(x) - x + 0.5 * std::log(2.0 * std::numbers::pi) +
         ix * (1.0 / 12.0 - ix2 * (1.0 / 360.0 - ix2 / 1260.0));
}

// One row's random stream.
class RowNoise {
 public:
  explicit RowNoise(std::uint64_t seed) : engine_(seed) {}

  // Uniform in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }

  double gaussian() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double r = std::sqrt(-2.0 * std::log(1.0 - uniform()));  // 1 - u in (0, 1]
    const double phi = 2.0 * std::numbers::pi * uniform();
    spare_ = r * std::sin(phi);
    has_spare_ = true;
    return r * std::cos(phi);
  }

  double poisson(double mean) {
    if (mean <= 0.0) return 0.0;
    if (mean < 10.0) {
      // Count uniforms whose running product stays above exp(-mean).
      const double limit = std::exp(-mean);
      double product = uniform();
      double k = 0.0;
      while (product > limit) {
        k += 1.0;
        product *= uniform();
      }
      return k;
    }
    // PTRS (Hoermann 1993), constants from the paper.
    const double s = std::sqrt(mean), log_mean = std::log(mean);
    const double b = 0.931 + 2.53 * s;
    const double a = -0.059 + 0.02483 * b;
    const double inv_alpha = 1.1239 + 1.1328 / (b - 3.4);
    const double v_r = 0.9277 - 3.6224 / (b - 2.0);
    for (;;) {
      const double u = uniform() - 0.5;
      const double v = uniform();
      const double us = 0.5 - std::abs(u);
      const double k = std::floor((2.0 * a / us + b) * u + mean + 0.43);
      if (us >= 0.07 && v <= v_r) return k;
      if (k < 0.0 || (us < 0.013 && v > us)) continue;
      if (std::log(v) + std::log(inv_alpha) - std::log(a / (us * us) + b) <=
          -mean + k * log_mean - log_factorial(k))
        return k;
    }
  }

 private:
  std::mt19937_64 engine_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace

void SensorOptions::validate() const {
  if (!(std::isfinite(photons_at_unity) && photons_at_unity > 0.0 && photons_at_unity <= 1e9))
    throw std::invalid_argument(fmt::format(
        "sensor: photons_at_unity must be in (0, 1e9] photons per pixel, got {}", photons_at_unity));
  if (!(std::isfinite(quantum_efficiency) && quantum_efficiency > 0.0 && quantum_efficiency <= 1.0))
    throw std::invalid_argument(fmt::format(
        "sensor: quantum_efficiency must be in (0, 1], got {}", quantum_efficiency));
  if (!finite_in(full_well_e, 1.0, 1e8))
    throw std::invalid_argument(
        fmt::format("sensor: full_well_e must be in [1, 1e8] electrons, got {}", full_well_e));
  if (!(std::isfinite(dark_signal_e) && dark_signal_e >= 0.0 && dark_signal_e < full_well_e))
    throw std::invalid_argument(fmt::format(
        "sensor: dark_signal_e must be in [0, full_well_e = {}) electrons, got {}", full_well_e,
        dark_signal_e));
  if (!finite_in(read_noise_e, 0.0, 1e5))
    throw std::invalid_argument(
        fmt::format("sensor: read_noise_e must be in [0, 1e5] electrons, got {}", read_noise_e));
  if (bit_depth < 8 || bit_depth > 16)
    throw std::invalid_argument(
        fmt::format("sensor: bit_depth must be in 8..16, got {}", bit_depth));
  if (gain_dn_per_e &&
      !(std::isfinite(*gain_dn_per_e) && *gain_dn_per_e > 0.0 && *gain_dn_per_e <= 1e4))
    throw std::invalid_argument(fmt::format(
        "sensor: gain_dn_per_e must be in (0, 1e4] DN per electron (or unset: full well -> top "
        "DN), got {}",
        *gain_dn_per_e));
}

int SensorOptions::max_dn() const { return (1 << bit_depth) - 1; }

double SensorOptions::system_gain_dn_per_e() const {
  return gain_dn_per_e ? *gain_dn_per_e : static_cast<double>(max_dn()) / full_well_e;
}

cv::Mat apply_sensor(const cv::Mat& irradiance, const SensorOptions& o) {
  o.validate();
  if (irradiance.empty() || irradiance.type() != CV_32FC1)
    throw std::invalid_argument(fmt::format(
        "apply_sensor: the irradiance must be a non-empty single-channel float (CV_32FC1) image, "
        "got type {} of {} x {}",
        irradiance.type(), irradiance.cols, irradiance.rows));
  cv::Point bad;
  if (!cv::checkRange(irradiance, true, &bad))
    throw std::invalid_argument(fmt::format(
        "apply_sensor: the irradiance has a non-finite value at pixel (x {}, y {})", bad.x, bad.y));

  const double photo_e_per_unit = o.quantum_efficiency * o.photons_at_unity;
  const double k = o.system_gain_dn_per_e();
  const double max_dn = o.max_dn();
  // A mean this far above the full well saturates with certainty (the
  // Poisson tail below it is < 1e-100): skip the draw, which also keeps
  // absurd inputs from reaching the sampler.
  const double certain_saturation = 4.0 * o.full_well_e + 1000.0;
  const bool eight_bit = o.bit_depth == 8;
  cv::Mat out(irradiance.size(), eight_bit ? CV_8UC1 : CV_16UC1);

  cv::parallel_for_(cv::Range(0, irradiance.rows), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      RowNoise noise(splitmix64(splitmix64(o.seed) ^ static_cast<std::uint64_t>(y)));
      const float* in = irradiance.ptr<float>(y);
      for (int x = 0; x < irradiance.cols; ++x) {
        const double mean_e = std::max(0.0, static_cast<double>(in[x])) * photo_e_per_unit;
        double e = mean_e >= certain_saturation ? mean_e : noise.poisson(mean_e);
        e += o.dark_signal_e;
        if (o.read_noise_e > 0.0) e += o.read_noise_e * noise.gaussian();
        // The pixel (and the ADC range) saturates at the full well.
        e = std::min(e, o.full_well_e);
        const double dn = std::clamp(std::floor(k * e + 0.5), 0.0, max_dn);
        if (eight_bit)
          out.ptr<std::uint8_t>(y)[x] = static_cast<std::uint8_t>(dn);
        else
          out.ptr<std::uint16_t>(y)[x] = static_cast<std::uint16_t>(dn);
      }
    }
  });
  return out;
}

namespace {
double checked_signal_e(const SensorOptions& o, double input_level, const char* what) {
  o.validate();
  if (!std::isfinite(input_level))
    throw std::invalid_argument(
        fmt::format("{}: input_level must be finite, got {}", what, input_level));
  return std::max(0.0, input_level) * o.quantum_efficiency * o.photons_at_unity;
}
double quantisation_variance_e2(const SensorOptions& o) {
  const double k = o.system_gain_dn_per_e();
  return (1.0 / 12.0) / (k * k);
}
}  // namespace

double sensor_mean_dn(const SensorOptions& o, double input_level) {
  const double s = checked_signal_e(o, input_level, "sensor_mean_dn");
  return o.system_gain_dn_per_e() * (s + o.dark_signal_e);
}

double sensor_sigma_dn(const SensorOptions& o, double input_level) {
  const double s = checked_signal_e(o, input_level, "sensor_sigma_dn");
  const double k = o.system_gain_dn_per_e();
  return std::sqrt(k * k * (o.read_noise_e * o.read_noise_e + s) + 1.0 / 12.0);
}

double snr_db(const SensorOptions& o, double input_level) {
  const double s = checked_signal_e(o, input_level, "snr_db");
  if (s <= 0.0) return -std::numeric_limits<double>::infinity();
  const double noise_e2 = o.read_noise_e * o.read_noise_e + quantisation_variance_e2(o) + s;
  return 20.0 * std::log10(s / std::sqrt(noise_e2));
}

double photons_at_unity_for_snr_db(const SensorOptions& o, double target_snr_db,
                                   double input_level) {
  o.validate();
  if (!std::isfinite(target_snr_db))
    throw std::invalid_argument(fmt::format(
        "photons_at_unity_for_snr_db: the target SNR must be finite, got {} dB", target_snr_db));
  if (!(std::isfinite(input_level) && input_level > 0.0))
    throw std::invalid_argument(fmt::format(
        "photons_at_unity_for_snr_db: input_level must be > 0, got {}", input_level));
  const double snr2 = std::pow(10.0, target_snr_db / 10.0);
  const double a = o.read_noise_e * o.read_noise_e + quantisation_variance_e2(o);
  const double s = 0.5 * (snr2 + std::sqrt(snr2 * snr2 + 4.0 * snr2 * a));
  if (s + o.dark_signal_e >= o.full_well_e) {
    // Shot noise caps the SNR at about sqrt(full well): 10 log10(full_well_e) dB.
    throw std::invalid_argument(fmt::format(
        "an SNR of {} dB needs {:.0f} signal electrons, but the full well holds {:g}: raise "
        "full_well_e above {:.0f} (the shot-noise limit is about 10 log10(full_well_e) = {:.1f} "
        "dB) or ask for less",
        target_snr_db, s, o.full_well_e, s + o.dark_signal_e, 10.0 * std::log10(o.full_well_e)));
  }
  return s / (o.quantum_efficiency * input_level);
}

}  // namespace tactres
