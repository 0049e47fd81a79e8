#include "tactres/profiles/profile_fit.h"

#include "tactres/profiles/profile_sampler.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>

#include <ceres/ceres.h>
#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/core/hal/hal.hpp>

namespace tactres {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

// Parameter vector layout.
enum : int { kB0 = 0, kB1, kLogNu0, kBeta, kContrast, kB2, kShift, kParamCount };

// The model on the FFT grid, with its derivatives, for one parameter vector.
class GridModel {
 public:
  // Grid point j sits at u_j = u_start + j * bin, j < n_fft (the tail past
  // the bins is padding against wrap-around). Sampling the continuous
  // spectrum G(nu_k) and inverting the DFT gives g(u_j) exactly for a
  // band-limited product S^ T; T decays long before the grid's Nyquist.
  // The profile is real, so only nu_k >= 0 is kept (OpenCV's CCS packing).
  // movable: whether the bars' boxes (not a complement window) go into a
  // spectrum of their own, which evaluate() shifts.
  GridModel(const ProfileData& d, Signature sig, bool movable) : d_(d) {
    n_fft_ = cv::getOptimalDFTSize(2 * d.bin_count);
    while (n_fft_ % 2) n_fft_ = cv::getOptimalDFTSize(n_fft_ + 1);
    const int half = n_fft_ / 2;
    dnu_ = 1.0 / (n_fft_ * d.bin_mm);
    const double u_start = d.bin_center_mm(0);
    std::vector<std::complex<double>> S(half + 1, 0.0), M(movable ? half + 1 : 0, 0.0);
    // S^(nu) = sum level (e^{-2 pi i nu a} - e^{-2 pi i nu b}) / (2 pi i nu);
    // the phase factors advance by a constant rotation per frequency step.
    for (const IdealBox& b : d.ideal) {
      std::vector<std::complex<double>>& into = movable && !is_complement_box(d, b) ? M : S;
      const double a0 = b.u0_mm - u_start, a1 = b.u1_mm - u_start;
      const std::complex<double> w0 = std::polar(1.0, -kTwoPi * dnu_ * a0);
      const std::complex<double> w1 = std::polar(1.0, -kTwoPi * dnu_ * a1);
      std::complex<double> z0 = 1.0, z1 = 1.0;
      into[0] += b.level * (a1 - a0);
      for (int k = 1; k <= half; ++k) {
        z0 *= w0;
        z1 *= w1;
        // (z0 - z1) / (2 pi i nu) as a product: a complex division costs several.
        into[k] += b.level * (z0 - z1) * std::complex<double>(0, -1.0 / (kTwoPi * k * dnu_));
      }
    }
    auto finish = [&](std::complex<double> v, int k) {
      const double nu = k * dnu_;
      if (sig == Signature::shading) v *= std::complex<double>(0, kTwoPi * nu);  // d/du
      v *= std::exp(-0.5 * kTwoPi * kTwoPi * d.bin_spread_var_mm2 * nu * nu);    // bin averaging
      return v / d.bin_mm;  // continuous integral -> DFT coefficient
    };
    s_re_.resize(half + 1);
    s_im_.resize(half + 1);
    log_nu_.resize(half + 1);
    for (int k = 0; k <= half; ++k) {
      const std::complex<double> v = finish(S[k], k);
      s_re_[k] = v.real();
      s_im_[k] = v.imag();
      log_nu_[k] = k > 0 ? std::log(k * dnu_) : 0.0;
    }
    for (int k = 0; k < static_cast<int>(M.size()); ++k) moving_.push_back(finish(M[k], k));
    // The buffers every evaluation fills, and the inverse DFT planned once:
    // a fit evaluates the model 10-20 times, and cv::dft plans the
    // transform again on every call (a fifth of the fit), as allocating the
    // buffers each time cost a tenth.
    for (cv::Mat* m : {&spectrum_, &spectrum_lognu0_, &spectrum_beta_, &spectrum_shift_, &conv_, &d_lognu0_, &d_beta_,
                       &d_shift_})
      m->create(1, n_fft_, CV_64F);
    inverse_dft_ = cv::hal::DFT2D::create(
        n_fft_, 1, CV_64F, 1, 1, CV_HAL_DFT_INVERSE | CV_HAL_DFT_SCALE | CV_HAL_DFT_REAL_OUTPUT | CV_HAL_DFT_IS_CONTINUOUS);
  }

  // The model on the grid, (D S (*) h)(u_j), and with `derivatives` its
  // derivatives in log nu0 and beta (and in the shift, when the bars move),
  // into conv(), d_lognu0(), d_beta() and d_shift().
  void evaluate(double log_nu0, double beta, double shift_mm, bool derivatives) const {
    const int half = n_fft_ / 2;
    const bool moving = !moving_.empty();
    // The bars' phase factor e^{-2 pi i nu s}, advanced by one rotation a step.
    const std::complex<double> step = std::polar(1.0, -kTwoPi * dnu_ * shift_mm);
    std::complex<double> phase = 1.0;
    // q grows with nu (beta > 0): past q = 40, T and T q are below 2e-16
    // of T(0) = 1, beyond what a double adds to it, and are set to zero
    // without their exponentials (blurred profiles end there early).
    constexpr double kNegligibleQ = 40;
    bool negligible = false;
    for (int k = 0; k <= half; ++k) {
      // q = (nu / nu0)^beta, through logs: one exp instead of a pow.
      const double log_a = log_nu_[k] - log_nu0;
      const double q = k == 0 || negligible ? 0.0 : std::exp(beta * log_a);
      negligible = negligible || q > kNegligibleQ;
      const double T = k > 0 && negligible ? 0.0 : std::exp(-q);
      // dT/dlog nu0 = T q beta ; dT/dbeta = -T q ln(a)
      if (moving && k > 0) phase *= step;
      const std::complex<double> bars = moving ? moving_[k] * phase : 0.0;
      const std::complex<double> v = std::complex<double>(s_re_[k], s_im_[k]) + bars;
      put(spectrum_, k, v * T);
      if (derivatives) {
        put(spectrum_lognu0_, k, v * (T * q * beta));
        put(spectrum_beta_, k, k > 0 ? v * (-T * q * log_a) : 0.0);
        // d/ds of e^{-2 pi i nu s}: -2 pi i nu.
        if (moving) put(spectrum_shift_, k, bars * std::complex<double>(0, -kTwoPi * k * dnu_) * T);
      }
    }
    inverse(spectrum_, conv_);
    if (derivatives) {
      inverse(spectrum_lognu0_, d_lognu0_);
      inverse(spectrum_beta_, d_beta_);
      if (moving) inverse(spectrum_shift_, d_shift_);
    }
  }
  const double* conv() const { return conv_.ptr<double>(0); }
  const double* d_lognu0() const { return d_lognu0_.ptr<double>(0); }
  const double* d_beta() const { return d_beta_.ptr<double>(0); }
  const double* d_shift() const { return d_shift_.ptr<double>(0); }

  int grid_size() const { return d_.bin_count; }
  bool moving() const { return !moving_.empty(); }

 private:
  // Writes v as the k-th coefficient in CCS layout: Re0, Re1, Im1, ...,
  // Re(N/2) (an imaginary part at nu = 0 and at Nyquist has no place there,
  // and is dropped).
  void put(cv::Mat& ccs, int k, std::complex<double> v) const {
    double* p = ccs.ptr<double>(0);
    const int half = n_fft_ / 2;
    if (k == 0) p[0] = v.real();
    else if (k == half) p[n_fft_ - 1] = v.real();
    else {
      p[2 * k - 1] = v.real();
      p[2 * k] = v.imag();
    }
  }

  // The first bin_count values of the inverse DFT are the grid; the rest is padding.
  void inverse(const cv::Mat& ccs, cv::Mat& out) const { inverse_dft_->apply(ccs.data, ccs.step, out.data, out.step); }

  const ProfileData& d_;
  int n_fft_ = 0;
  double dnu_ = 0;  // frequency step, cycles/mm
  std::vector<double> s_re_, s_im_, log_nu_;  // the fixed part of the spectrum
  std::vector<std::complex<double>> moving_;   // the bars' part, when they move
  mutable cv::Mat spectrum_, spectrum_lognu0_, spectrum_beta_, spectrum_shift_, conv_, d_lognu0_, d_beta_, d_shift_;
  cv::Ptr<cv::hal::DFT2D> inverse_dft_;
};

// One residual per non-empty bin in the fit range, weighted by 1/sigma.
class ProfileCost final : public ceres::CostFunction {
 public:
  ProfileCost(const ProfileData& d, const GridModel& model, double contrast_slope_per_mm)
      : model_(model), contrast_slope_per_mm_(contrast_slope_per_mm) {
    const int n = model.grid_size();
    for (int i = d.fit_begin; i < d.fit_end; ++i) {
      if (!(d.count[i] > 0 && std::isfinite(d.value[i])) || d.bound_at(i) == 2) continue;
      // Cubic (Catmull-Rom) interpolation of the grid model at the bin's
      // mean u: linear interpolation would attenuate the fundamental by ~1%
      // at quarter-pixel grid spacing. The weights depend on the data only.
      Bin b;
      const double g = (d.u_mean_mm[i] - d.u0_mm) / d.bin_mm - 0.5;
      // Clamped as a double: casting an out-of-range g to int is UB.
      b.grid = static_cast<int>(std::clamp(std::floor(g), 1.0, n - 3.0));
      const double t = std::clamp(g - b.grid, 0.0, 1.0);
      const double t2 = t * t, t3 = t2 * t;
      b.weight = {-0.5 * t3 + t2 - 0.5 * t, 1.5 * t3 - 2.5 * t2 + 1, -1.5 * t3 + 2 * t2 + 0.5 * t, 0.5 * t3 - 0.5 * t2};
      b.u_mm = d.u_mean_mm[i];
      b.value = d.value[i];
      b.sigma = d.sigma[i];
      b.bound = d.bound_at(i);
      bound_count_ += b.bound != 0;
      bins_.push_back(b);
    }
    set_num_residuals(static_cast<int>(bins_.size()));
    mutable_parameter_block_sizes()->push_back(kParamCount);
  }
  int residual_count() const { return static_cast<int>(bins_.size()); }
  int bound_count() const { return bound_count_; }

  // RMS of (model - data) in image units, unweighted.
  double residual_rms(const double* x) const {
    std::vector<double> r(bins_.size());
    evaluate(x, r.data(), nullptr, contrast_slope_per_mm_);
    double ss = 0;
    for (size_t k = 0; k < r.size(); ++k) ss += std::pow(r[k] * bins_[k].sigma, 2);
    return r.empty() ? 0.0 : std::sqrt(ss / r.size());
  }

  // RMS of the signature alone (the model minus its background: the same
  // parameters with no contrast), in image units, over the fitted bins.
  double signal_rms(const double* x) const {
    std::vector<double> with(bins_.size()), without(bins_.size());
    double x0[kParamCount];
    std::copy(x, x + kParamCount, x0);
    x0[kContrast] = 0;
    evaluate(x, with.data(), nullptr, contrast_slope_per_mm_);
    evaluate(x0, without.data(), nullptr, 0.0);
    double ss = 0;
    for (size_t k = 0; k < with.size(); ++k) ss += std::pow((with[k] - without[k]) * bins_[k].sigma, 2);
    return with.empty() ? 0.0 : std::sqrt(ss / with.size());
  }

  bool Evaluate(double const* const* params, double* residuals, double** jacobians) const override {
    evaluate(params[0], residuals, jacobians ? jacobians[0] : nullptr, contrast_slope_per_mm_);
    return true;
  }

 private:
  struct Bin {
    int grid = 1;                   // grid index of the second of four interpolation nodes
    std::array<double, 4> weight{};  // Catmull-Rom weights of nodes grid-1 .. grid+2
    double u_mm = 0, value = 0, sigma = 1;
    signed char bound = 0;  // ProfileData::bound
  };

  // The weighted residuals (and their Jacobian, row-major, if `jacobian`),
  // with the contrast x[kContrast] + slope u at u.
  void evaluate(const double* x, double* residuals, double* jacobian, double contrast_slope_per_mm) const {
    const bool want_j = jacobian != nullptr;
    model_.evaluate(x[kLogNu0], x[kBeta], x[kShift], want_j);
    const double* conv = model_.conv();
    const double* dn = want_j ? model_.d_lognu0() : nullptr;
    const double* db = want_j ? model_.d_beta() : nullptr;
    const double* ds = want_j && model_.moving() ? model_.d_shift() : nullptr;
    for (size_t r = 0; r < bins_.size(); ++r) {
      const Bin& b = bins_[r];
      auto at = [&](const double* v) {
        const double* p = v + b.grid - 1;
        return b.weight[0] * p[0] + b.weight[1] * p[1] + b.weight[2] * p[2] + b.weight[3] * p[3];
      };
      const double u = b.u_mm;
      const double light = x[kB0] + x[kB1] * u + x[kB2] * u * u;
      const double sig = at(conv);
      const double c = x[kContrast] + contrast_slope_per_mm * u;
      const double model = light * (1 + c * sig);
      const double w = 1.0 / b.sigma;
      residuals[r] = (model - b.value) * w;
      // A bound the model keeps costs nothing and pulls on nothing.
      const bool kept = (b.bound < 0 && residuals[r] <= 0) || (b.bound > 0 && residuals[r] >= 0);
      if (kept) {
        residuals[r] = 0;
        if (want_j) std::fill_n(jacobian + r * kParamCount, kParamCount, 0.0);
        continue;
      }
      if (want_j) {
        double* J = jacobian + r * kParamCount;
        J[kB0] = (1 + c * sig) * w;
        J[kB1] = u * (1 + c * sig) * w;
        J[kLogNu0] = light * c * at(dn) * w;
        J[kBeta] = light * c * at(db) * w;
        J[kContrast] = light * sig * w;
        J[kB2] = u * u * (1 + c * sig) * w;
        J[kShift] = ds ? light * c * at(ds) * w : 0.0;
      }
    }
  }

  const GridModel& model_;
  double contrast_slope_per_mm_;
  std::vector<Bin> bins_;
  int bound_count_ = 0;
};

}  // namespace

double ProfileData::ideal_at(double u) const {
  double s = 0;
  for (const IdealBox& b : ideal)
    if (u >= b.u0_mm && u < b.u1_mm) s += b.level;
  return s;
}

void ProfileFitOptions::validate() const {
  if (!(beta_min >= 0.5 && beta_max <= 8 && beta_min <= beta_max))
    throw std::invalid_argument("profile fit: beta range must satisfy 0.5 <= min <= max <= 8");
  if (!fit_contrast && !(std::isfinite(contrast) && contrast != 0))
    throw std::invalid_argument("profile fit: a fixed contrast must be finite and non-zero");
  if (!std::isfinite(contrast_slope_per_mm))
    throw std::invalid_argument("profile fit: the contrast's slope must be finite");
  if (max_iterations < 1) throw std::invalid_argument("profile fit: max_iterations must be >= 1");
  if (fit_shift && !(std::isfinite(max_shift_mm) && max_shift_mm > 0))
    throw std::invalid_argument("profile fit: a fitted shift needs a finite max_shift_mm > 0");
}

double ProfileFit::transfer(double f) const {
  return std::exp(-std::pow(f / nu0_per_mm, beta));
}

namespace {
// dT/d(log nu0) and dT/d(beta) at f.
std::pair<double, double> transfer_gradient(const ProfileFit& fit, double f) {
  const double m = fit.transfer(f);
  const double q = std::pow(f / fit.nu0_per_mm, fit.beta);
  return {m * q * fit.beta, -m * q * std::log(f / fit.nu0_per_mm)};
}
}  // namespace

double ProfileFit::transfer_sigma(double f) const {
  const auto [dm_dlognu0, dm_dbeta] = transfer_gradient(*this, f);
  const double var = dm_dlognu0 * dm_dlognu0 * var_log_nu0 + dm_dbeta * dm_dbeta * var_beta +
                     2 * dm_dlognu0 * dm_dbeta * cov_log_nu0_beta;
  return std::sqrt(std::max(var, 0.0));
}

double ProfileFit::transfer_change_unbounded(double f) const {
  const auto [dm_dlognu0, dm_dbeta] = transfer_gradient(*this, f);
  return dm_dlognu0 * unbounded_step_log_nu0 + dm_dbeta * unbounded_step_beta;
}

// Why `data` cannot be fitted at all, or null. Non-finite geometry or
// weights would reach the model as NaN positions (found by fuzzing: an
// undefined float-to-int cast in the cost).
static const char* unfit_data(const ProfileData& data) {
  const int n = data.bin_count;
  const size_t nn = static_cast<size_t>(std::max(n, 0));
  if (n < 8 || data.bin_mm <= 0 || data.fit_begin < 0 || data.fit_end > n ||
      data.value.size() != nn || data.u_mean_mm.size() != nn || data.sigma.size() != nn ||
      data.count.size() != nn || !(data.bound.empty() || data.bound.size() == nn))
    return "profile too short or inconsistent";
  bool finite = std::isfinite(data.u0_mm) && std::isfinite(data.bin_mm) &&
                std::isfinite(data.bin_spread_var_mm2) && data.bin_spread_var_mm2 >= 0;
  for (const IdealBox& b : data.ideal)
    finite = finite && std::isfinite(b.u0_mm) && std::isfinite(b.u1_mm) && std::isfinite(b.level);
  for (int i = std::max(data.fit_begin, 0); i < std::min(data.fit_end, n); ++i)
    if (data.count[i] > 0 && std::isfinite(data.value[i]))
      finite = finite && std::isfinite(data.u_mean_mm[i]) && std::isfinite(data.sigma[i]) && data.sigma[i] > 0;
  return finite ? nullptr : "profile has non-finite positions, weights or pattern";
}

// The fit's start: the ground level from bins where the ideal pattern is
// empty (from all bins if none is); the LSF about one pixel wide (bins are
// a fraction of a pixel).
static void start_point(const ProfileData& data, const ProfileFitOptions& options, double x[kParamCount]) {
  double ground = 0, weight = 0;
  for (int i = data.fit_begin; i < data.fit_end; ++i)
    if (data.count[i] > 0 && std::isfinite(data.value[i]) &&
        std::abs(data.ideal_at(data.u_mean_mm[i])) < 0.01) {
      ground += data.value[i];
      weight += 1;
    }
  if (weight == 0)
    for (int i = data.fit_begin; i < data.fit_end; ++i)
      if (data.count[i] > 0 && std::isfinite(data.value[i])) {
        ground += data.value[i];
        weight += 1;
      }
  const double nu0_start = options.start_nu0_per_mm > 0 ? options.start_nu0_per_mm : 0.1 / data.bin_mm;
  const double beta_start =
      options.fit_shape && options.start_beta > 0
          ? std::clamp(options.start_beta, options.beta_min, options.beta_max)
          : 2.0;
  const double start[kParamCount] = {ground / weight, 0.0,
                                     std::clamp(std::log(nu0_start), std::log(1e-3), std::log(2.0 / data.bin_mm)),
                                     beta_start, options.fit_contrast ? -0.5 : options.contrast, 0.0, 0.0};
  std::copy(start, start + kParamCount, x);
}

// The parameters the options hold fixed, and the bounds of the free ones.
static void constrain(ceres::Problem& problem, double* x, const ProfileData& data,
                      const ProfileFitOptions& options) {
  std::vector<int> fixed;
  if (!options.fit_shape) fixed.push_back(kBeta);
  if (!options.fit_contrast) fixed.push_back(kContrast);
  if (!options.quadratic_background) fixed.push_back(kB2);
  if (!options.fit_shift) fixed.push_back(kShift);
  if (!fixed.empty()) problem.SetManifold(x, new ceres::SubsetManifold(kParamCount, fixed));
  problem.SetParameterLowerBound(x, kLogNu0, std::log(1e-3));
  problem.SetParameterUpperBound(x, kLogNu0, std::log(2.0 / data.bin_mm));
  // A printed pattern's contrast is the ink/ground reflectance ratio minus
  // one: ink cannot reflect less than nothing. Unbounded, a fit to a
  // profile the model cannot describe (flare, dust rings, a resampled
  // photograph) reached c = -1.8, which halved every m scaled by it.
  if (options.fit_contrast && options.signature == Signature::albedo)
    problem.SetParameterLowerBound(x, kContrast, -1.0);
  if (options.fit_shift) {
    problem.SetParameterLowerBound(x, kShift, -options.max_shift_mm);
    problem.SetParameterUpperBound(x, kShift, options.max_shift_mm);
  }
  if (options.fit_shape) {
    problem.SetParameterLowerBound(x, kBeta, options.beta_min);
    problem.SetParameterUpperBound(x, kBeta, options.beta_max);
  }
}

// ProfileFit::unbounded_step_*: the Gauss-Newton step -C J^T r from the
// solution x, with C the (unscaled) covariance of the free parameters
// (zero rows for the held ones) and J, r the weighted residuals' Jacobian
// and values; beta's sigma as the fit reports it (scaled by chi^2).
// `outward`: -1 on the lower bound, +1 on the upper; a step back into the
// range leaves the bound by nothing. The step lifts every bound at once (a
// contrast at -1 or a shift at its range's edge moves with it): it says
// where the data point, not a refit.
static void set_unbounded_step(const ProfileCost& cost, const double* x, const double* cov, double scale,
                               int outward, ProfileFit& out) {
  const size_t n = static_cast<size_t>(cost.residual_count());
  std::vector<double> r(n), jacobian(n * kParamCount);
  const double* parameters[] = {x};
  double* jacobians[] = {jacobian.data()};
  if (!cost.Evaluate(parameters, r.data(), jacobians)) return;
  double gradient[kParamCount] = {};
  for (size_t i = 0; i < n; ++i)
    for (int k = 0; k < kParamCount; ++k) gradient[k] += jacobian[i * kParamCount + k] * r[i];
  double step[kParamCount] = {};
  for (int j = 0; j < kParamCount; ++j)
    for (int k = 0; k < kParamCount; ++k) step[j] -= cov[j * kParamCount + k] * gradient[k];
  const double sd_beta = std::sqrt(std::max(0.0, scale * cov[kBeta * kParamCount + kBeta]));
  out.unbounded_step_log_nu0 = step[kLogNu0];
  out.unbounded_step_beta = step[kBeta];
  out.beta_bound_sigmas = sd_beta > 0 ? std::max(0.0, outward * step[kBeta]) / sd_beta : 0.0;
}

// The fit in the data's own units (fit_profile scales them first).
static ProfileFit fit_scaled(const ProfileData& data, const ProfileFitOptions& options) {
  ProfileFit out;

  GridModel model(data, options.signature, options.fit_shift);
  auto* cost = new ProfileCost(data, model, options.contrast_slope_per_mm);
  const int free_params = 3 + (options.fit_shape ? 1 : 0) + (options.fit_contrast ? 1 : 0) +
                          (options.quadratic_background ? 1 : 0) + (options.fit_shift ? 1 : 0);
  // Bounds carry no noise to count degrees of freedom with: the
  // measurements alone must pin the model down.
  const int measured = cost->residual_count() - cost->bound_count();
  if (measured < free_params + 3) {
    delete cost;
    out.problem = "too few samples across the bars";
    return out;
  }

  double x[kParamCount];
  start_point(data, options, x);

  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  problem.AddResidualBlock(cost, nullptr, x);
  constrain(problem, x, data, options);

  ceres::Solver::Options so;
  // Up to seven parameters: the normal equations are tiny, and Cholesky on them
  // costs less than a QR of the tall Jacobian (Ceres scales its columns).
  so.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  // With bounds, Ceres follows every trust-region step with a projected
  // line search that evaluates the Jacobian again: half of all model
  // evaluations, for no change in the converged fit (ceres-solver issue
  // 187 calls it "not terribly effective"). Steps are still projected onto
  // the bounds.
  so.max_num_line_search_step_size_iterations = 0;
  so.max_num_iterations = options.max_iterations;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  out.solver_report = summary.BriefReport();
  out.residual_count = cost->residual_count();
  out.bound_count = cost->bound_count();
  if (!summary.IsSolutionUsable()) {
    out.problem = "solver failed: " + summary.message;
    return out;
  }

  const int dof = std::max(1, measured - free_params);
  out.chi2_reduced = 2 * summary.final_cost / dof;
  out.residual_rms = cost->residual_rms(x);
  out.signal_rms = cost->signal_rms(x);

  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  co.null_space_rank = 0;
  co.min_reciprocal_condition_number = 1e-14;
  ceres::Covariance covariance(co);
  std::vector<std::pair<const double*, const double*>> blocks = {{x, x}};
  if (!covariance.Compute(blocks, &problem)) {
    out.problem = "the fit is degenerate (no contrast, or the pattern is not in the data)";
    return out;
  }
  double cov[kParamCount * kParamCount];
  covariance.GetCovarianceBlock(x, x, cov);
  const double scale = std::max(1.0, out.chi2_reduced);
  if (options.fit_shape && options.beta_min < options.beta_max &&
      (x[kBeta] <= options.beta_min || x[kBeta] >= options.beta_max))
    set_unbounded_step(*cost, x, cov, scale, x[kBeta] <= options.beta_min ? -1 : 1, out);
  out.var_log_nu0 = cov[kLogNu0 * kParamCount + kLogNu0] * scale;
  out.var_beta = options.fit_shape ? cov[kBeta * kParamCount + kBeta] * scale : 0.0;
  out.cov_log_nu0_beta = options.fit_shape ? cov[kLogNu0 * kParamCount + kBeta] * scale : 0.0;
  const double var_shift = options.fit_shift ? cov[kShift * kParamCount + kShift] * scale : 0.0;
  out.shift_sigma_mm = std::sqrt(std::max(0.0, var_shift));
  out.contrast = x[kContrast];
  out.contrast_sigma =
      options.fit_contrast ? std::sqrt(std::max(0.0, cov[kContrast * kParamCount + kContrast] * scale)) : 0.0;
  out.nu0_per_mm = std::exp(x[kLogNu0]);
  out.beta = x[kBeta];
  out.b0 = x[kB0];
  out.b1_per_mm = x[kB1];
  out.shift_mm = x[kShift];
  out.usable = std::isfinite(out.nu0_per_mm) && std::isfinite(out.beta) && std::isfinite(out.shift_mm) &&
               std::isfinite(out.var_log_nu0) && std::isfinite(out.var_beta) && std::isfinite(var_shift);
  if (!out.usable) out.problem = "the fit produced non-finite parameters";
  return out;
}

// The power of two nearest the median magnitude of the fitted bins' values
// (1 when there is none).
static double typical_magnitude(const ProfileData& data) {
  std::vector<double> magnitude;
  for (int i = std::max(data.fit_begin, 0); i < std::min(data.fit_end, data.bin_count); ++i)
    if (data.count[i] > 0 && std::isfinite(data.value[i]) && data.value[i] != 0)
      magnitude.push_back(std::abs(data.value[i]));
  if (magnitude.empty()) return 1.0;
  std::nth_element(magnitude.begin(), magnitude.begin() + magnitude.size() / 2, magnitude.end());
  return std::exp2(std::round(std::log2(magnitude[magnitude.size() / 2])));
}

// The fit runs on the values divided by their typical magnitude, and the
// levels it finds are scaled back: Ceres' covariance is not invariant to
// the data's units (its rank test compares the Jacobian's columns, and the
// levels' columns scale with 1 / units where the blur's do not). A linear
// float image scaled by 1e6 read every element "degenerate". A power of
// two divides exactly.
ProfileFit fit_profile(const ProfileData& data, const ProfileFitOptions& options) {
  options.validate();
  if (const char* problem = unfit_data(data)) {
    ProfileFit out;
    out.problem = problem;
    return out;
  }
  const double unit = typical_magnitude(data);
  if (unit == 1.0) return fit_scaled(data, options);
  ProfileData in_units = data;
  for (double& v : in_units.value) v /= unit;
  for (double& v : in_units.sigma) v /= unit;
  ProfileFit out = fit_scaled(in_units, options);
  out.b0 *= unit;
  out.b1_per_mm *= unit;
  out.residual_rms *= unit;
  out.signal_rms *= unit;
  return out;
}

}  // namespace tactres
