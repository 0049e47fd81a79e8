#pragma once
// The profile model: what a bar triplet (or the reference patch) looks like
// after the sensor's chain, fitted with Ceres.
//
// Along the profile coordinate u (mm, across the bars), the capture is
//
//   P(u) = (B0 + B1 u [+ B2 u^2]) * (1 + c * [D (S (*) h)](u))
//
// S(u)  the ideal strip coverage of every artwork shape in the sampled strip
//       (1 = ink or raised, 0 = ground), known from the layout;
// h     the chain's line spread function, with transfer
//       T(nu) = exp(-(nu / nu0)^beta), nu in cycles/mm. beta = 2 is a
//       Gaussian; beta ~ 1.3-1.6 follows diffraction-limited optics and
//       beta ~ 2.5-3 a defocus disc, so one family stays nearly unbiased for
//       all three (the finite three-bar window is modelled exactly, not
//       approximated by a fundamental amplitude; docs/ARCHITECTURE.md, "The measurand");
// D     identity for printed (albedo) targets; d/du for a relief seen
//       through a gel under (linearised) shading, whose image is the
//       surface slope along the light direction: an edge-like signature;
// c     the contrast scale: the ink/ground reflectance ratio minus one
//       (albedo; bounded below by -1 when fitted) or the slope response (shading), measured on the
//       reference patch and held fixed for the elements; c + c' u when the
//       step changes across the strip (a light that turns over the target:
//       c' from the gain field, held fixed; 0 otherwise);
// B0+B1 u  the local illumination, multiplicative, so uneven light does not
//       bias m.
//
// The measurand m(f) = T(f) at the element's frequency f; its standard
// error comes from the Ceres covariance of (nu0, beta), plus the patch's
// contrast uncertainty.
//
// The profile is evaluated on a uniform grid by FFT of the exact, continuous
// spectrum of S (a sum of boxes), then interpolated (cubic) at each bin's mean
// sample position: the bins are point samples of the pixel-integrated image,
// so no extra bin filter enters the model.

#include <string>
#include <vector>

namespace tactres {

enum class Signature { albedo, shading };

// One piece of the ideal strip profile: S(u) += level on [u0, u1).
struct IdealBox {
  double u0_mm = 0, u1_mm = 0;
  double level = 1;  // fraction of the strip covered (1 for a full bar)
};

// Binned samples along u. Bin i covers [u0 + i*bin, u0 + (i+1)*bin).
struct ProfileData {
  double u0_mm = 0.0;
  double bin_mm = 0.0;
  int bin_count = 0;
  std::vector<IdealBox> ideal;  // S(u), exact
  std::vector<double> value;    // mean sample value per bin (NaN if empty)
  std::vector<double> u_mean_mm;  // mean u of the samples in the bin
  std::vector<double> sigma;    // standard error of the bin mean
  std::vector<int> count;       // samples in the bin
  // Per bin, whether its mean is a measurement (0) or only a bound on the
  // light before clipping: a pixel clipped at black read at least its true
  // value, so a bin holding one reads an upper bound (-1: true <= value);
  // one clipped at saturation, a lower bound (+1: true >= value). The fit
  // treats a bound as a one-sided residual (a censored, Tobit-style fit):
  // clipped bar cores still say the bars went at least that deep. Empty:
  // every bin a measurement. 2: both kinds of clipping, no information.
  std::vector<signed char> bound;
  // Mean variance of the sample positions u within a bin (mm^2): averaging
  // samples spread over a bin blurs the profile by that much, which the
  // model applies as a Gaussian of that variance (exact to second order).
  double bin_spread_var_mm2 = 0.0;
  // Bins [fit_begin, fit_end) take part in the fit; the rest only extend the
  // grid so that blur from neighbours is modelled without wrap-around.
  int fit_begin = 0, fit_end = 0;

  double bin_center_mm(int i) const { return u0_mm + (i + 0.5) * bin_mm; }
  double ideal_at(double u_mm) const;  // S(u)
  int bound_at(int i) const { return bound.empty() ? 0 : bound[i]; }
};

struct ProfileFitOptions {
  Signature signature = Signature::albedo;
  bool fit_contrast = false;    // true on the reference patch
  double contrast = -0.9;       // c, used when !fit_contrast
  // c', the step's change per mm of u about the strip's centre (u = 0),
  // held fixed: a gain field's gradient along u (docs/CONVENTIONS.md, "A
  // light that varies over the target"). The three bars of an element on
  // the flank of a spot shade 2-3x differently; a constant c would misread
  // that as blur.
  double contrast_slope_per_mm = 0;
  bool fit_shape = true;        // false: beta fixed at 2 (Gaussian)
  // Adds B2 u^2 to the light: wide profiles (the reference patch) can span a
  // curved illumination, e.g. the flank of a hot spot.
  bool quadratic_background = false;
  double beta_min = 1.0, beta_max = 4.0;
  int max_iterations = 50;
  // Start of the LSF parameters (nu0 in cycles/mm, beta); 0 = default. The
  // chain's blur is shared by all elements, so the previous element's fit
  // is a good start and saves iterations.
  double start_nu0_per_mm = 0, start_beta = 0;
  // true: the pattern's bars (not a negative chart's complement window,
  // profile_sampler.h) move along u by a fitted shift within
  // +-max_shift_mm, one more parameter (ProfileFit::shift_mm). Chart mode
  // places a pattern from its binarised bars, a tenth of a bar off or so;
  // one fit with the shift free replaces a search over shifted ideals.
  bool fit_shift = false;
  double max_shift_mm = 0;

  void validate() const;  // throws std::invalid_argument
};

struct ProfileFit {
  bool usable = false;          // false: nothing below may be read
  std::string problem;          // why not usable
  double nu0_per_mm = 0, beta = 2;
  double contrast = 0, contrast_sigma = 0;
  double b0 = 0, b1_per_mm = 0;
  double shift_mm = 0, shift_sigma_mm = 0;  // with fit_shift (sigma: with covariance)
  // Covariance of (log nu0, beta) from Ceres, scaled by the reduced chi^2
  // when the model fits worse than the noise (never scaled down).
  double var_log_nu0 = 0, var_beta = 0, cov_log_nu0_beta = 0;
  double chi2_reduced = 0;
  // With the shape fitted and beta ending on one of its bounds: where the
  // fit would go with the bounds lifted, to first order (one Gauss-Newton
  // step from the fit, in log nu0 and beta), and how many of beta's
  // sigmas that step leaves the bound by. All 0 when beta ends inside its
  // range, or the shape is held. A step of several sigmas means the data
  // press on the bound: the LSF family ends there, and m with it.
  double unbounded_step_log_nu0 = 0, unbounded_step_beta = 0;
  double beta_bound_sigmas = 0;
  double residual_rms = 0;  // RMS of model - data, in image units
  double signal_rms = 0;    // RMS of the fitted signature alone (model - background), image units
  int residual_count = 0;   // bins fitted: measurements and bounds
  int bound_count = 0;      // of them, bounds (clipped bins, ProfileData::bound)
  std::string solver_report;

  double transfer(double lp_per_mm) const;        // T(f) = m
  double transfer_sigma(double lp_per_mm) const;  // its standard error
  // T(f)'s change to first order along the unbounded step (0 off the bounds).
  double transfer_change_unbounded(double lp_per_mm) const;
};

ProfileFit fit_profile(const ProfileData& data, const ProfileFitOptions& options);

}  // namespace tactres
