#pragma once
// Sensor effect of the scene simulator: the EMVA 1288 linear camera model
// (EMVA Standard 1288, Release 4.0 Linear, 2021, section 2 "Sensitivity,
// linearity and noise").
//
// A pixel receiving mu_p photons during the exposure collects
// Poisson(eta mu_p) photo-electrons (shot noise), saturating at the full-well
// capacity; to them the dark signal mu_d and the temporal dark noise
// (Gaussian, sigma_d electrons) add; the system gain K (DN per electron)
// converts to digital numbers, which are rounded and clamped to the bit
// depth. Below saturation the model predicts
//   mu_y      = K (eta mu_p + mu_d)
//   sigma_y^2 = K^2 (sigma_d^2 + eta mu_p) + sigma_q^2,  sigma_q^2 = 1/12 DN^2
// (EMVA 1288 eqs. for mean and temporal variance). Dark signal non-uniformity
// and photo-response non-uniformity (DSNU, PRNU) are not modelled.

#include <cstdint>
#include <optional>

#include <opencv2/core/mat.hpp>

namespace tactres {

struct SensorOptions {
  // Mean photons per pixel for an input irradiance of 1.0 (the renderer's
  // white, e.g. the reference patch under unit illumination), (0, 1e9].
  // With the other defaults, 1.0 fills 78 % of the full well (eta mu_p =
  // 7800 e-): white stays below saturation, and an illumination gain of
  // ~1.3 or more over-exposes.
  double photons_at_unity = 13000.0;
  double quantum_efficiency = 0.6;  // eta, (0, 1]
  double full_well_e = 10000.0;     // saturation capacity in electrons, [1, 1e8]
  double dark_signal_e = 5.0;       // mean dark signal mu_d in electrons, [0, full well)
  double read_noise_e = 3.0;        // temporal dark noise sigma_d in electrons, [0, 1e5]
  // System gain K in DN per electron, (0, 1e4]. Unset: (2^bit_depth - 1) /
  // full_well_e, so that the full well maps to the top DN.
  std::optional<double> gain_dn_per_e;
  int bit_depth = 8;                // 8..16; the output is CV_8U for 8, CV_16U above
  std::uint64_t seed = 0;           // noise seed: same seed, same bytes

  void validate() const;  // throws std::invalid_argument naming the field and its range

  // K: gain_dn_per_e if set, else (2^bit_depth - 1) / full_well_e.
  double system_gain_dn_per_e() const;
  // 2^bit_depth - 1.
  int max_dn() const;
};

// Simulates one exposure. `irradiance` is CV_32FC1 in units of the input
// level (1.0 -> photons_at_unity mean photons); negative values (ringing of a
// band-limited PSF) collect zero photons; non-finite values are rejected with
// std::invalid_argument. Returns DN (raw, not shifted to the container's top
// bits) as CV_8UC1 for bit_depth 8, else CV_16UC1.
//
// Deterministic: each row draws from its own std::mt19937_64 seeded from
// (seed, row), and the Poisson and Gaussian samplers are implemented here
// (not std::poisson_distribution, whose algorithm is implementation-defined),
// so the output bytes depend only on the inputs and the seed: not on the
// thread count, nor on the standard library.
cv::Mat apply_sensor(const cv::Mat& irradiance, const SensorOptions& options);

// The model's mean and standard deviation in DN at a uniform input level,
// ignoring saturation (EMVA 1288 linear model, quantisation included).
double sensor_mean_dn(const SensorOptions& options, double input_level);
double sensor_sigma_dn(const SensorOptions& options, double input_level);

// EMVA 1288 signal-to-noise ratio at `input_level` in dB:
// 20 log10((mu_y - mu_y.dark) / sigma_y) = 20 log10(eta mu_p / sqrt(sigma_d^2 +
// sigma_q^2 / K^2 + eta mu_p)). Ignores saturation (the linear model's
// value); -inf for input_level <= 0. Throws for invalid options.
double snr_db(const SensorOptions& options, double input_level);

// photons_at_unity that gives `target_snr_db` at `input_level`, the other
// options unchanged: the positive root of s^2 = SNR^2 (a + s), s = eta mu_p,
// a = sigma_d^2 + sigma_q^2 / K^2. For scenes that ask for "about 40 dB SNR".
// Throws std::invalid_argument if target_snr_db is not finite or input_level
// is not positive.
double photons_at_unity_for_snr_db(const SensorOptions& options, double target_snr_db,
                                   double input_level = 1.0);

}  // namespace tactres
