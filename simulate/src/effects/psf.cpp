// PSF blur through analytic OTFs.
//
// References:
// - J. W. Goodman, Introduction to Fourier Optics, 3rd ed. (2005):
//   section 2.1 (Fourier-Bessel transform of circ: the pillbox's transfer
//   2 J1(2 pi R nu) / (2 pi R nu)) and section 6.3 (OTF of the aberration-free
//   circular pupil in incoherent light, (2/pi)(acos x - x sqrt(1 - x^2)),
//   cutoff 1 / (lambda N)).
// - The defocus disc is the geometric-optics limit of defocus (blur circle
//   of uniform irradiance), valid when the focusing error is many waves;
//   Goodman section 6.4 discusses the focusing error and this limit.
// - The Gaussian is the usual stand-in for a well-corrected lens plus sensor
//   (its transfer is exp(-2 pi^2 sigma^2 nu^2)).

#include "tactres/simulate/effects/psf.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>
#include <opencv2/core.hpp>

namespace tactres {

namespace {

constexpr double kPi = std::numbers::pi;

bool in_closed(double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; }

// 2 J1(x) / x and its derivative -2 J2(x) / x (from d/dx [J1(x)/x] = -J2(x)/x).
double jinc(double x) { return std::abs(x) < 1e-8 ? 1.0 : 2.0 * std::cyl_bessel_j(1.0, x) / x; }
double jinc_slope(double x) { return std::abs(x) < 1e-8 ? 0.0 : -2.0 * std::cyl_bessel_j(2.0, x) / x; }

double diffraction_otf(double x) {
  if (x >= 1.0) return 0.0;
  return (2.0 / kPi) * (std::acos(x) - x * std::sqrt(1.0 - x * x));
}

// The pillbox OTF tabulated for cubic Hermite interpolation: libstdc++'s
// cyl_bessel_j costs ~2 us per call, far too slow for every bin of a large
// DFT. With node spacing h and a = 2 pi R, the Hermite error is at most
// h^4 / 384 * max|f''''| <= (a h)^4 / 3072 (the 4th derivative of 2 J1(x)/x
// is bounded by E[t^4] = 1/8 for t the projection of a uniform unit disc);
// a h = 0.04 keeps it below 1e-9.
class DiscOtfTable {
 public:
  DiscOtfTable(double radius_px, double nu_max) : a_(2.0 * kPi * radius_px) {
    h_ = 0.04 / std::max(a_, 1e-12);
    const auto n = static_cast<std::size_t>(std::ceil(nu_max / h_)) + 2;
    value_.resize(n);
    slope_.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const double x = a_ * h_ * static_cast<double>(i);
      value_[i] = jinc(x);
      slope_[i] = a_ * jinc_slope(x);  // d/dnu
    }
  }

  double operator()(double nu) const {
    const double t = nu / h_;
    const auto i = std::min(static_cast<std::size_t>(t), value_.size() - 2);
    const double s = t - static_cast<double>(i);
    const double s2 = s * s, s3 = s2 * s;
    return (2 * s3 - 3 * s2 + 1) * value_[i] + (s3 - 2 * s2 + s) * h_ * slope_[i] +
           (-2 * s3 + 3 * s2) * value_[i + 1] + (s3 - s2) * h_ * slope_[i + 1];
  }

 private:
  double a_;
  double h_;
  std::vector<double> value_, slope_;
};

// A PSF's characteristic radius in sensor pixels, for sizing the padding.
double psf_extent_px(const PsfOptions& o) {
  switch (o.kind) {
    case PsfOptions::gaussian: return 4.0 * o.sigma_px;
    case PsfOptions::defocus_disc: return o.radius_px;
    case PsfOptions::diffraction:
      // The Airy pattern's tails fall off only as r^-3 (the energy outside
      // radius r as 1/r: 2 / (pi v), v = pi r / (lambda N)), so no finite pad
      // holds all of it. 8 Airy radii (1.22 lambda N each) leave ~2 %
      // outside, and that part mostly sees reflected image content, which
      // is the continuation the reflection assumes anyway.
      return 8.0 * 1.22 / diffraction_cutoff_cycles_per_px(o);
  }
  return 0.0;
}

bool is_identity(const PsfOptions& o) {
  return (o.kind == PsfOptions::gaussian && o.sigma_px == 0.0) ||
         (o.kind == PsfOptions::defocus_disc && o.radius_px == 0.0);
}

// Smallest even size >= n that cv::dft handles fast (a product of 2, 3, 5).
// Even sizes keep the CCS packing to one layout (Nyquist row and column
// present).
int even_dft_size(int n) {
  int m = cv::getOptimalDFTSize(n);
  while (m % 2 != 0) m = cv::getOptimalDFTSize(m + 1);
  return m;
}

}  // namespace

void PsfOptions::validate() const {
  switch (kind) {
    case gaussian:
      if (!in_closed(sigma_px, 0.0, 200.0))
        throw std::invalid_argument(fmt::format(
            "gaussian PSF: sigma_px must be in [0, 200] sensor pixels, got {}", sigma_px));
      return;
    case defocus_disc:
      if (!in_closed(radius_px, 0.0, 200.0))
        throw std::invalid_argument(fmt::format(
            "defocus_disc PSF: radius_px must be in [0, 200] sensor pixels, got {}", radius_px));
      return;
    case diffraction:
      if (!in_closed(f_number, 0.5, 128.0))
        throw std::invalid_argument(
            fmt::format("diffraction PSF: f_number must be in [0.5, 128], got {}", f_number));
      if (!in_closed(wavelength_um, 0.2, 20.0))
        throw std::invalid_argument(fmt::format(
            "diffraction PSF: wavelength_um must be in [0.2, 20] um, got {}", wavelength_um));
      if (!in_closed(pixel_pitch_um, 0.3, 100.0))
        throw std::invalid_argument(fmt::format(
            "diffraction PSF: pixel_pitch_um must be in [0.3, 100] um, got {}", pixel_pitch_um));
      return;
  }
  throw std::invalid_argument(fmt::format(
      "PSF kind {} is unknown: use gaussian, defocus_disc or diffraction", static_cast<int>(kind)));
}

const char* to_string(PsfOptions::Kind kind) {
  switch (kind) {
    case PsfOptions::gaussian: return "gaussian";
    case PsfOptions::defocus_disc: return "defocus_disc";
    case PsfOptions::diffraction: return "diffraction";
  }
  return "unknown";
}

PsfOptions::Kind psf_kind_from_string(const std::string& name) {
  for (auto k : {PsfOptions::gaussian, PsfOptions::defocus_disc, PsfOptions::diffraction})
    if (name == to_string(k)) return k;
  throw std::invalid_argument(fmt::format(
      "PSF kind \"{}\" is unknown: use gaussian, defocus_disc or diffraction", name));
}

double diffraction_cutoff_cycles_per_px(const PsfOptions& o) {
  // nu_c = 1 / (lambda N) cycles per unit length; times the pitch (same unit)
  // gives cycles per pixel.
  return o.pixel_pitch_um / (o.wavelength_um * o.f_number);
}

double psf_mtf(const PsfOptions& o, double cycles_per_px) {
  o.validate();
  if (!std::isfinite(cycles_per_px))
    throw std::invalid_argument(
        fmt::format("psf_mtf: the frequency must be finite, got {}", cycles_per_px));
  const double nu = std::abs(cycles_per_px);
  switch (o.kind) {
    case PsfOptions::gaussian: return std::exp(-2.0 * kPi * kPi * o.sigma_px * o.sigma_px * nu * nu);
    case PsfOptions::defocus_disc: return jinc(2.0 * kPi * o.radius_px * nu);
    case PsfOptions::diffraction: return diffraction_otf(nu / diffraction_cutoff_cycles_per_px(o));
  }
  return 1.0;
}

void apply_psf(cv::Mat& image, const PsfOptions& o, double pixel_scale) {
  o.validate();
  if (image.empty() || image.type() != CV_32FC1)
    throw std::invalid_argument(fmt::format(
        "apply_psf: the image must be a non-empty single-channel float (CV_32FC1) image, got "
        "type {} of {} x {}",
        image.type(), image.cols, image.rows));
  if (!(std::isfinite(pixel_scale) && pixel_scale > 0.0 && pixel_scale <= 16.0))
    throw std::invalid_argument(fmt::format(
        "apply_psf: pixel_scale (image pixel size in sensor pixels, 1/oversample) must be in "
        "(0, 16], got {}",
        pixel_scale));
  if (is_identity(o)) return;

  // Pad by reflection so that the circular convolution the DFT performs sees
  // a plausible continuation of the image instead of its opposite edge.
  const int pad = static_cast<int>(std::ceil(psf_extent_px(o) / pixel_scale)) + 8;
  const int rows = even_dft_size(image.rows + 2 * pad);
  const int cols = even_dft_size(image.cols + 2 * pad);
  cv::Mat spectrum;
  cv::copyMakeBorder(image, spectrum, pad, rows - image.rows - pad, pad, cols - image.cols - pad,
                     cv::BORDER_REFLECT | cv::BORDER_ISOLATED);
  cv::dft(spectrum, spectrum, 0);  // real input -> CCS-packed spectrum

  // Radial frequency of DFT bin (t, k) in cycles per sensor pixel:
  // hypot(k / cols, t / rows) / pixel_scale, for row frequency t in
  // [-rows/2, rows/2] and column frequency k in [0, cols/2].
  const double nu_max = std::hypot(0.5, 0.5) / pixel_scale * 1.001;
  std::unique_ptr<DiscOtfTable> disc;
  if (o.kind == PsfOptions::defocus_disc) disc = std::make_unique<DiscOtfTable>(o.radius_px, nu_max);
  const double nu_c = o.kind == PsfOptions::diffraction ? diffraction_cutoff_cycles_per_px(o) : 1.0;
  const double gauss_k = -2.0 * kPi * kPi * o.sigma_px * o.sigma_px;
  auto otf = [&](double nu) -> double {
    switch (o.kind) {
      case PsfOptions::gaussian: return std::exp(gauss_k * nu * nu);
      case PsfOptions::defocus_disc: return (*disc)(nu);
      case PsfOptions::diffraction: return diffraction_otf(nu / nu_c);
    }
    return 1.0;
  };

  // CCS layout for even rows x cols (see cv::dft): columns 2k-1, 2k hold
  // Re, Im of Y(r, k) for k in [1, cols/2 - 1] and every row r; column 0
  // holds Y(t, 0) and column cols-1 holds Y(t, cols/2), packed down the rows
  // as Re Y(0), (Re, Im) Y(t) in rows 2t-1, 2t for t in [1, rows/2 - 1], and
  // Re Y(rows/2) in the last row. The OTF is real and even in t, so row
  // frequencies t and rows - t share one evaluation.
  const int half_rows = rows / 2, half_cols = cols / 2;
  cv::parallel_for_(cv::Range(0, half_rows + 1), [&](const cv::Range& range) {
    std::vector<float> h(static_cast<std::size_t>(half_cols) + 1);
    for (int t = range.start; t < range.end; ++t) {
      const double v = static_cast<double>(t) / rows;
      for (int k = 0; k <= half_cols; ++k)
        h[k] = static_cast<float>(otf(std::hypot(static_cast<double>(k) / cols, v) / pixel_scale));
      auto scale_row = [&](int r) {
        float* p = spectrum.ptr<float>(r);
        for (int k = 1; k < half_cols; ++k) {
          p[2 * k - 1] *= h[k];
          p[2 * k] *= h[k];
        }
      };
      scale_row(t);
      if (t != 0 && t != half_rows) scale_row(rows - t);
      auto scale_edge_columns = [&](int r) {
        spectrum.at<float>(r, 0) *= h[0];
        spectrum.at<float>(r, cols - 1) *= h[half_cols];
      };
      if (t == 0) {
        scale_edge_columns(0);
      } else if (t == half_rows) {
        scale_edge_columns(rows - 1);
      } else {
        scale_edge_columns(2 * t - 1);
        scale_edge_columns(2 * t);
      }
    }
  });

  cv::dft(spectrum, spectrum, cv::DFT_INVERSE | cv::DFT_SCALE | cv::DFT_REAL_OUTPUT);
  spectrum(cv::Rect(pad, pad, image.cols, image.rows)).copyTo(image);
}

}  // namespace tactres
