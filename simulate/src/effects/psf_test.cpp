#include "tactres/simulate/effects/psf.h"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include <doctest/doctest.h>
#include <opencv2/core.hpp>

using namespace tactres;

namespace {

constexpr double kPi = std::numbers::pi;

PsfOptions gaussian(double sigma_px) {
  PsfOptions o;
  o.kind = PsfOptions::gaussian;
  o.sigma_px = sigma_px;
  return o;
}
PsfOptions disc(double radius_px) {
  PsfOptions o;
  o.kind = PsfOptions::defocus_disc;
  o.radius_px = radius_px;
  return o;
}
PsfOptions airy(double f_number, double wavelength_um, double pitch_um) {
  PsfOptions o;
  o.kind = PsfOptions::diffraction;
  o.f_number = f_number;
  o.wavelength_um = wavelength_um;
  o.pixel_pitch_um = pitch_um;
  return o;
}

// offset + amplitude * cos(2 pi (fx x + fy y) + phase), frequencies in cycles per image pixel.
cv::Mat sinusoid(int w, int h, double fx, double fy, double offset, double amplitude,
                 double phase) {
  cv::Mat m(h, w, CV_32FC1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      m.at<float>(y, x) =
          static_cast<float>(offset + amplitude * std::cos(2 * kPi * (fx * x + fy * y) + phase));
  return m;
}

// Least-squares amplitude of the sinusoid of known frequency (with a free
// offset and phase) over the image interior, `margin` pixels from each edge.
double fitted_amplitude(const cv::Mat& m, double fx, double fy, int margin) {
  double a[3][3] = {}, b[3] = {};
  for (int y = margin; y < m.rows - margin; ++y)
    for (int x = margin; x < m.cols - margin; ++x) {
      const double ph = 2 * kPi * (fx * x + fy * y);
      const double basis[3] = {1.0, std::cos(ph), std::sin(ph)};
      const double v = m.at<float>(y, x);
      for (int i = 0; i < 3; ++i) {
        b[i] += basis[i] * v;
        for (int j = 0; j < 3; ++j) a[i][j] += basis[i] * basis[j];
      }
    }
  // Solve the 3x3 normal equations by Gaussian elimination (well conditioned:
  // the interior spans several periods).
  for (int c = 0; c < 3; ++c)
    for (int r = c + 1; r < 3; ++r) {
      const double f = a[r][c] / a[c][c];
      for (int k = c; k < 3; ++k) a[r][k] -= f * a[c][k];
      b[r] -= f * b[c];
    }
  double coef[3];
  for (int r = 2; r >= 0; --r) {
    double s = b[r];
    for (int k = r + 1; k < 3; ++k) s -= a[r][k] * coef[k];
    coef[r] = s / a[r][r];
  }
  return std::hypot(coef[1], coef[2]);
}

}  // namespace

TEST_CASE("psf_mtf: closed-form values") {
  const PsfOptions g = gaussian(1.5);
  CHECK(psf_mtf(g, 0.0) == doctest::Approx(1.0));
  CHECK(psf_mtf(g, 1.0 / (2 * kPi * 1.5)) == doctest::Approx(std::exp(-0.5)).epsilon(1e-12));
  CHECK(psf_mtf(g, -0.1) == doctest::Approx(psf_mtf(g, 0.1)));

  const PsfOptions d = disc(2.0);
  CHECK(psf_mtf(d, 0.0) == doctest::Approx(1.0));
  // First zero of J1 at 3.831705970: contrast vanishes, then reverses.
  CHECK(std::abs(psf_mtf(d, 3.831705970207512 / (2 * kPi * 2.0))) < 1e-9);
  CHECK(psf_mtf(d, 0.4) < 0.0);
  // 2 J1(1)/1 = 0.880101171
  CHECK(psf_mtf(d, 1.0 / (2 * kPi * 2.0)) == doctest::Approx(0.8801011714).epsilon(1e-9));

  const PsfOptions a = airy(4.0, 0.5, 2.0);  // nu_c = 2 / (0.5 * 4) = 1 cycle/px
  CHECK(diffraction_cutoff_cycles_per_px(a) == doctest::Approx(1.0));
  CHECK(psf_mtf(a, 0.0) == doctest::Approx(1.0));
  // (2/pi)(acos 0.5 - 0.5 sqrt(0.75)) = 0.391002219
  CHECK(psf_mtf(a, 0.5) == doctest::Approx(0.3910022189).epsilon(1e-9));
  CHECK(psf_mtf(a, 1.0) == 0.0);
  CHECK(psf_mtf(a, 1.7) == 0.0);

  // A zero-width Gaussian or disc is the identity.
  CHECK(psf_mtf(gaussian(0.0), 0.3) == 1.0);
  CHECK(psf_mtf(disc(0.0), 0.3) == 1.0);
  CHECK_THROWS_AS(psf_mtf(g, std::nan("")), std::invalid_argument);
}

TEST_CASE("PsfOptions: validation and names") {
  CHECK_NOTHROW(PsfOptions{}.validate());
  CHECK_THROWS_AS(gaussian(-1.0).validate(), std::invalid_argument);
  CHECK_THROWS_AS(gaussian(std::nan("")).validate(), std::invalid_argument);
  CHECK_THROWS_AS(disc(500.0).validate(), std::invalid_argument);
  CHECK_THROWS_AS(airy(0.1, 0.55, 2.0).validate(), std::invalid_argument);
  CHECK_THROWS_AS(airy(2.8, 55.0, 2.0).validate(), std::invalid_argument);
  CHECK_THROWS_AS(airy(2.8, 0.55, 0.0).validate(), std::invalid_argument);
  // Only the chosen kind's fields matter.
  PsfOptions g = gaussian(1.0);
  g.radius_px = -5.0;
  CHECK_NOTHROW(g.validate());
  try {
    gaussian(-1.0).validate();
    FAIL("no throw");
  } catch (const std::invalid_argument& e) {
    CHECK(std::string(e.what()).find("[0, 200]") != std::string::npos);
  }

  for (auto k : {PsfOptions::gaussian, PsfOptions::defocus_disc, PsfOptions::diffraction})
    CHECK(psf_kind_from_string(to_string(k)) == k);
  CHECK_THROWS_AS(psf_kind_from_string("airy"), std::invalid_argument);

  cv::Mat wrong(8, 8, CV_8UC1, cv::Scalar(1));
  CHECK_THROWS_AS(apply_psf(wrong, gaussian(1.0)), std::invalid_argument);
  cv::Mat empty;
  CHECK_THROWS_AS(apply_psf(empty, gaussian(1.0)), std::invalid_argument);
  cv::Mat ok(8, 8, CV_32FC1, cv::Scalar(1));
  CHECK_THROWS_AS(apply_psf(ok, gaussian(1.0), 0.0), std::invalid_argument);
  CHECK_THROWS_AS(apply_psf(ok, gaussian(1.0), std::nan("")), std::invalid_argument);
}

TEST_CASE("apply_psf: a sinusoid's amplitude scales by psf_mtf") {
  struct Case {
    std::string name;
    PsfOptions options;
    double pixel_scale;
  };
  const std::vector<Case> cases = {
      {"gaussian", gaussian(1.3), 1.0},
      {"gaussian oversampled", gaussian(0.8), 0.5},
      {"disc", disc(2.5), 1.0},
      {"disc oversampled", disc(1.2), 0.5},
      {"diffraction", airy(8.0, 0.55, 2.0), 1.0},  // nu_c = 0.4545 cycles/px
      {"diffraction oversampled", airy(4.0, 0.55, 1.4), 0.5},  // 0.318 cycles/image px
  };
  const double magnitudes[] = {0.01, 0.04, 0.1, 0.17, 0.25, 0.33, 0.45};
  const double angles_deg[] = {0.0, 90.0, 30.0, 135.0, 58.0};
  const int w = 220, h = 180, margin = 40;
  double worst = 0.0;
  for (const Case& c : cases) {
    double case_worst = 0.0;
    for (double nu : magnitudes)
      for (double angle : angles_deg) {
        const double fx = nu * std::cos(angle * kPi / 180.0);
        const double fy = nu * std::sin(angle * kPi / 180.0);
        cv::Mat m = sinusoid(w, h, fx, fy, 0.5, 0.3, 0.7);
        apply_psf(m, c.options, c.pixel_scale);
        const double ratio = fitted_amplitude(m, fx, fy, margin) / 0.3;
        const double expected = std::abs(psf_mtf(c.options, nu / c.pixel_scale));
        CAPTURE(c.name);
        CAPTURE(nu);
        CAPTURE(angle);
        CHECK(std::abs(ratio - expected) < 1e-3);
        case_worst = std::max(case_worst, std::abs(ratio - expected));
      }
    MESSAGE(c.name << ": worst |amplitude ratio - psf_mtf| " << case_worst);
    worst = std::max(worst, case_worst);
  }
  MESSAGE("worst |amplitude ratio - psf_mtf| over all kinds, frequencies, angles: " << worst);
}

TEST_CASE("apply_psf: constant stays constant, energy is conserved") {
  for (const PsfOptions& o : {gaussian(2.0), disc(3.0), airy(5.6, 0.55, 2.0)}) {
    const std::string kind = to_string(o.kind);
    CAPTURE(kind);
    cv::Mat flat(97, 131, CV_32FC1, cv::Scalar(0.37));
    apply_psf(flat, o);
    double lo, hi;
    cv::minMaxLoc(flat, &lo, &hi);
    CHECK(std::abs(lo - 0.37) < 1e-6);
    CHECK(std::abs(hi - 0.37) < 1e-6);

    // A small pattern well inside the frame: its blur stays inside, so the
    // sum is conserved (the transfer at zero frequency is exactly 1).
    cv::Mat spot(160, 200, CV_32FC1, cv::Scalar(0));
    spot(cv::Rect(90, 70, 7, 4)).setTo(1.0);
    spot.at<float>(80, 100) = 3.0f;
    const double before = cv::sum(spot)[0];
    const double scale = 0.5;
    apply_psf(spot, o, scale);
    const double after = cv::sum(spot)[0];
    if (o.kind != PsfOptions::diffraction) {
      CHECK(after == doctest::Approx(before).epsilon(1e-4));
    } else {
      // The Airy pattern's energy outside radius r falls only as 1/r,
      // 2 / (pi v) with v = pi r / (lambda N): no frame holds all of it. The
      // loss stays below the tail beyond the nearest border (~66 px).
      const double lambda_n_img = 0.55 * 5.6 / 2.0 / scale;
      const double v_near = kPi * 66.0 / lambda_n_img;
      const double lost = (before - after) / before;
      CHECK(lost > 0.0);
      CHECK(lost < 2.0 / (kPi * v_near));
    }
  }
}

TEST_CASE("apply_psf: a blurred point has the Gaussian's second moment") {
  for (double scale : {1.0, 0.5}) {
    const double sigma_px = 2.0;
    const double sigma_img = sigma_px / scale;
    cv::Mat m(151, 161, CV_32FC1, cv::Scalar(0));
    const int cx = 80, cy = 75;
    m.at<float>(cy, cx) = 1.0f;
    apply_psf(m, gaussian(sigma_px), scale);
    double s = 0, sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
    for (int y = 0; y < m.rows; ++y)
      for (int x = 0; x < m.cols; ++x) {
        const double v = m.at<float>(y, x);
        s += v;
        sx += v * (x - cx);
        sy += v * (y - cy);
        sxx += v * (x - cx) * (x - cx);
        syy += v * (y - cy) * (y - cy);
        sxy += v * (x - cx) * (y - cy);
      }
    CAPTURE(scale);
    CHECK(s == doctest::Approx(1.0).epsilon(1e-5));
    CHECK(std::abs(sx / s) < 1e-4);
    CHECK(std::abs(sy / s) < 1e-4);
    CHECK(sxx / s == doctest::Approx(sigma_img * sigma_img).epsilon(1e-3));
    CHECK(syy / s == doctest::Approx(sigma_img * sigma_img).epsilon(1e-3));
    CHECK(std::abs(sxy / s) < 1e-3);
    // And the peak matches the sampled Gaussian's 1 / (2 pi sigma^2).
    CHECK(m.at<float>(cy, cx) ==
          doctest::Approx(1.0 / (2 * kPi * sigma_img * sigma_img)).epsilon(1e-3));
  }
}

TEST_CASE("apply_psf: zero-width PSFs and ROI images") {
  cv::Mat m = sinusoid(50, 40, 0.3, 0.1, 0.5, 0.4, 0.0);
  const cv::Mat before = m.clone();
  apply_psf(m, gaussian(0.0));
  apply_psf(m, disc(0.0));
  CHECK(cv::norm(m, before, cv::NORM_INF) == 0.0);

  // Blurring a view blurs only that view, as if it were its own image.
  cv::Mat big(60, 80, CV_32FC1, cv::Scalar(5.0));
  cv::Mat roi = big(cv::Rect(10, 10, 50, 40));
  before.copyTo(roi);
  cv::Mat alone = before.clone();
  apply_psf(roi, gaussian(1.5));
  apply_psf(alone, gaussian(1.5));
  CHECK(cv::norm(roi, alone, cv::NORM_INF) < 1e-6);
  CHECK(big.at<float>(5, 5) == 5.0f);
  CHECK(big.at<float>(55, 75) == 5.0f);
}
