#include "tactres/simulate/effects/sensor_model.h"

#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>

#include <doctest/doctest.h>
#include <opencv2/core.hpp>

using namespace tactres;

namespace {

struct Stats {
  double mean = 0.0;
  double variance = 0.0;  // unbiased
  double n = 0.0;
};

Stats stats_of(const cv::Mat& dn) {
  cv::Mat d;
  dn.convertTo(d, CV_64F);
  Stats s;
  s.n = static_cast<double>(d.total());
  s.mean = cv::sum(d)[0] / s.n;
  cv::Mat centred = d - s.mean;
  s.variance = centred.dot(centred) / (s.n - 1.0);
  return s;
}

cv::Mat uniform_input(int w, int h, double level) {
  return cv::Mat(h, w, CV_32FC1, cv::Scalar(level));
}

double poisson_pmf(double mean, int k) {
  return std::exp(-mean + k * std::log(mean) - std::lgamma(k + 1.0));
}

}  // namespace

TEST_CASE("SensorOptions: validation, gain and depth") {
  SensorOptions o;
  CHECK_NOTHROW(o.validate());
  CHECK(o.max_dn() == 255);
  CHECK(o.system_gain_dn_per_e() == doctest::Approx(255.0 / 10000.0));
  o.bit_depth = 12;
  CHECK(o.system_gain_dn_per_e() == doctest::Approx(4095.0 / 10000.0));
  o.gain_dn_per_e = 0.25;
  CHECK(o.system_gain_dn_per_e() == 0.25);

  auto throws_mentioning = [](SensorOptions bad, const std::string& text) {
    try {
      bad.validate();
      return false;
    } catch (const std::invalid_argument& e) {
      return std::string(e.what()).find(text) != std::string::npos;
    }
  };
  SensorOptions bad;
  bad.quantum_efficiency = 1.5;
  CHECK(throws_mentioning(bad, "(0, 1]"));
  bad = {};
  bad.bit_depth = 7;
  CHECK(throws_mentioning(bad, "8..16"));
  bad = {};
  bad.bit_depth = 17;
  CHECK(throws_mentioning(bad, "8..16"));
  bad = {};
  bad.photons_at_unity = 0.0;
  CHECK(throws_mentioning(bad, "photons_at_unity"));
  bad = {};
  bad.full_well_e = std::nan("");
  CHECK(throws_mentioning(bad, "full_well_e"));
  bad = {};
  bad.dark_signal_e = 20000.0;
  CHECK(throws_mentioning(bad, "dark_signal_e"));
  bad = {};
  bad.read_noise_e = -1.0;
  CHECK(throws_mentioning(bad, "read_noise_e"));
  bad = {};
  bad.gain_dn_per_e = 0.0;
  CHECK(throws_mentioning(bad, "gain_dn_per_e"));

  cv::Mat wrong(4, 4, CV_64FC1, cv::Scalar(0.5));
  CHECK_THROWS_AS(apply_sensor(wrong, SensorOptions{}), std::invalid_argument);
  cv::Mat with_nan = uniform_input(4, 4, 0.5);
  with_nan.at<float>(2, 3) = std::numeric_limits<float>::quiet_NaN();
  try {
    apply_sensor(with_nan, SensorOptions{});
    FAIL("no throw");
  } catch (const std::invalid_argument& e) {
    CHECK(std::string(e.what()).find("(x 3, y 2)") != std::string::npos);
  }

  SensorOptions eight;
  CHECK(apply_sensor(uniform_input(8, 4, 0.5), eight).type() == CV_8UC1);
  SensorOptions ten;
  ten.bit_depth = 10;
  const cv::Mat out10 = apply_sensor(uniform_input(8, 4, 5.0), ten);
  CHECK(out10.type() == CV_16UC1);
  double hi;
  cv::minMaxLoc(out10, nullptr, &hi);
  CHECK(hi == 1023.0);
}

TEST_CASE("apply_sensor: mean and variance follow the EMVA 1288 model") {
  // 12-bit: the temporal noise (>= 1.2 DN) is well above the quantisation
  // step, where sigma_q^2 = 1/12 DN^2 holds; the dark level (50 e- -> 20 DN)
  // keeps the noise from being clipped at 0 DN.
  SensorOptions o;
  o.bit_depth = 12;
  o.dark_signal_e = 50.0;
  o.read_noise_e = 3.0;
  o.seed = 1288;
  const double k = o.system_gain_dn_per_e();
  const double eta_p = o.quantum_efficiency * o.photons_at_unity;
  const int w = 512, h = 512;
  // Levels from 4.7 photo-electrons (the product-of-uniforms Poisson branch)
  // through the PTRS branch up to 7800 e- (78 % of the full well, 24 sigma
  // below it, so saturation is negligible).
  double worst_mean_z = 0.0, worst_var_z = 0.0;
  for (double level : {0.0006, 0.002, 0.01, 0.05, 0.2, 0.5, 1.0}) {
    const Stats s = stats_of(apply_sensor(uniform_input(w, h, level), o));
    const double mu_e = eta_p * level;
    const double mu_y = k * (mu_e + o.dark_signal_e);
    const double var_y = k * k * (o.read_noise_e * o.read_noise_e + mu_e) + 1.0 / 12.0;
    CHECK(sensor_mean_dn(o, level) == doctest::Approx(mu_y));
    CHECK(sensor_sigma_dn(o, level) == doctest::Approx(std::sqrt(var_y)));
    // Standard errors of the estimators: sigma / sqrt(n) for the mean;
    // sigma^2 sqrt((2 + kappa) / n) for the variance, with the excess
    // kurtosis kappa <= 1 (Poisson: 1 / mean; Gaussian and uniform
    // quantisation parts: 0 and -1.2).
    const double se_mean = std::sqrt(var_y / s.n);
    const double se_var = var_y * std::sqrt(3.0 / s.n);
    const double mean_z = (s.mean - mu_y) / se_mean;
    const double var_z = (s.variance - var_y) / se_var;
    CAPTURE(level);
    CAPTURE(s.mean);
    CAPTURE(mu_y);
    CAPTURE(s.variance);
    CAPTURE(var_y);
    CHECK(std::abs(mean_z) < 5.0);
    CHECK(std::abs(var_z) < 5.0);
    worst_mean_z = std::max(worst_mean_z, std::abs(mean_z));
    worst_var_z = std::max(worst_var_z, std::abs(var_z));
  }
  MESSAGE("EMVA check over 7 levels, 512x512 each: worst |mean z| " << worst_mean_z
                                                                    << ", worst |variance z| "
                                                                    << worst_var_z);
}

TEST_CASE("apply_sensor: the photo-electron count is Poisson distributed") {
  // Gain 1 DN/e-, no dark signal or read noise, a full well out of reach:
  // the DN are the Poisson draws themselves.
  SensorOptions o;
  o.bit_depth = 16;
  o.gain_dn_per_e = 1.0;
  o.dark_signal_e = 0.0;
  o.read_noise_e = 0.0;
  o.full_well_e = 1e8;
  o.quantum_efficiency = 1.0;
  o.photons_at_unity = 1.0;
  o.seed = 7;
  for (double mean : {0.3, 3.5, 9.9, 10.0, 31.0, 1000.0}) {
    const cv::Mat dn = apply_sensor(uniform_input(400, 250, mean), o);
    std::map<int, double> counts;
    for (int y = 0; y < dn.rows; ++y)
      for (int x = 0; x < dn.cols; ++x) counts[dn.at<std::uint16_t>(y, x)] += 1.0;
    const double n = static_cast<double>(dn.total());
    // Chi-square over the bins expecting >= 20 counts, tails pooled.
    double chi2 = 0.0, expected_in_bins = 0.0, observed_in_bins = 0.0;
    int bins = 0;
    for (int kk = 0; kk < 4000; ++kk) {
      const double expected = n * poisson_pmf(mean, kk);
      if (expected < 20.0) continue;
      const double observed = counts.count(kk) ? counts[kk] : 0.0;
      chi2 += (observed - expected) * (observed - expected) / expected;
      expected_in_bins += expected;
      observed_in_bins += observed;
      ++bins;
    }
    const double tail_expected = n - expected_in_bins, tail_observed = n - observed_in_bins;
    if (tail_expected >= 20.0) {
      chi2 += (tail_observed - tail_expected) * (tail_observed - tail_expected) / tail_expected;
      ++bins;
    }
    const double dof = bins - 1;
    CAPTURE(mean);
    CAPTURE(chi2);
    CAPTURE(dof);
    CHECK(bins >= 2);
    CHECK(chi2 < dof + 5.0 * std::sqrt(2.0 * dof));
  }
}

TEST_CASE("apply_sensor: saturation, negative input, determinism") {
  SensorOptions o;  // 8-bit
  for (double level : {2.0, 1e3, 1e30}) {
    const cv::Mat dn = apply_sensor(uniform_input(64, 32, level), o);
    double lo, hi;
    cv::minMaxLoc(dn, &lo, &hi);
    CAPTURE(level);
    CHECK(lo == 255.0);
    CHECK(hi == 255.0);
  }
  SensorOptions twelve = o;
  twelve.bit_depth = 12;
  twelve.read_noise_e = 30.0;  // noise does not pull saturated pixels below the top
  {
    double lo, hi;
    cv::minMaxLoc(apply_sensor(uniform_input(64, 32, 3.0), twelve), &lo, &hi);
    CHECK(lo == 4095.0);
    CHECK(hi == 4095.0);
  }

  // Negative irradiance (PSF ringing) collects no photons: a dark frame.
  const cv::Mat dark = apply_sensor(uniform_input(50, 40, 0.0), twelve);
  const cv::Mat negative = apply_sensor(uniform_input(50, 40, -0.3), twelve);
  CHECK(cv::norm(dark, negative, cv::NORM_INF) == 0.0);

  // Same seed, same bytes, whatever the thread count; another seed differs.
  cv::Mat ramp(120, 200, CV_32FC1);
  for (int y = 0; y < ramp.rows; ++y)
    for (int x = 0; x < ramp.cols; ++x) ramp.at<float>(y, x) = static_cast<float>(x) / ramp.cols;
  twelve.seed = 42;
  const int threads = cv::getNumThreads();
  const cv::Mat a = apply_sensor(ramp, twelve);
  cv::setNumThreads(1);
  const cv::Mat b = apply_sensor(ramp, twelve);
  cv::setNumThreads(threads);
  CHECK(cv::norm(a, b, cv::NORM_INF) == 0.0);
  twelve.seed = 43;
  const cv::Mat c = apply_sensor(ramp, twelve);
  CHECK(cv::countNonZero(a != c) > ramp.total() / 2);
  // Rows are independent streams: no two rows of a uniform frame repeat.
  const cv::Mat flat = apply_sensor(uniform_input(300, 64, 0.5), twelve);
  int repeats = 0;
  for (int y = 1; y < flat.rows; ++y) repeats += cv::norm(flat.row(y), flat.row(0), cv::NORM_INF) == 0.0;
  CHECK(repeats == 0);
}

TEST_CASE("snr_db: model value, measured value and inverse") {
  SensorOptions o;  // defaults: 8-bit, K = 0.0255 DN/e-
  // 7800 e- signal; noise^2 = 9 + (1/12) / K^2 + 7800 e-^2.
  const double k = 255.0 / 10000.0;
  const double expected = 20.0 * std::log10(7800.0 / std::sqrt(9.0 + 1.0 / 12.0 / (k * k) + 7800.0));
  CHECK(snr_db(o, 1.0) == doctest::Approx(expected).epsilon(1e-12));
  CHECK(snr_db(o, 1.0) == doctest::Approx(38.84).epsilon(1e-3));
  CHECK(snr_db(o, 0.0) == -std::numeric_limits<double>::infinity());
  CHECK(snr_db(o, 0.1) < snr_db(o, 1.0));

  // Against a simulated exposure (12-bit so that the noise is resolved).
  SensorOptions m = o;
  m.bit_depth = 12;
  m.dark_signal_e = 50.0;
  m.seed = 3;
  const Stats dark = stats_of(apply_sensor(uniform_input(512, 256, 0.0), m));
  const Stats lit = stats_of(apply_sensor(uniform_input(512, 256, 0.3), m));
  const double measured = 20.0 * std::log10((lit.mean - dark.mean) / std::sqrt(lit.variance));
  // The SNR estimate's relative standard error is ~sqrt(1 / (2 n)): 0.0014
  // -> 0.012 dB; allow 0.1 dB.
  CHECK(std::abs(measured - snr_db(m, 0.3)) < 0.1);

  // The inverse: photons for a requested SNR.
  SensorOptions big = o;
  big.full_well_e = 30000.0;
  big.bit_depth = 12;
  big.photons_at_unity = photons_at_unity_for_snr_db(big, 40.0);
  CHECK(snr_db(big, 1.0) == doctest::Approx(40.0).epsilon(1e-12));
  big.photons_at_unity = photons_at_unity_for_snr_db(big, 30.0, 0.5);
  CHECK(snr_db(big, 0.5) == doctest::Approx(30.0).epsilon(1e-12));
  // 40 dB needs ~10^4 signal electrons: more than a 10000 e- well holds.
  try {
    photons_at_unity_for_snr_db(o, 40.0);
    FAIL("no throw");
  } catch (const std::invalid_argument& e) {
    CHECK(std::string(e.what()).find("full_well_e") != std::string::npos);
  }
  CHECK_THROWS_AS(photons_at_unity_for_snr_db(o, 20.0, 0.0), std::invalid_argument);
}
