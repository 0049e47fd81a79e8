#include "tactres/measure/element_pipeline.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include <fmt/format.h>

namespace tactres {

SampledProfile sample_placement(const cv::Mat& lum, const ElementPlacement& placement,
                                const ProfileSamplingOptions& sampling, bool complement, double clip_level) {
  SampledProfile p = sample_strip(lum, *placement.plane, *placement.artwork, placement.strip, sampling, clip_level);
  if (complement && p.in_view) complement_ideal(p.data);
  return p;
}

std::vector<std::vector<SampledProfile>> sample_jobs(const cv::Mat& lum, const std::vector<ElementJob>& jobs,
                                                     double clip_level) {
  std::vector<std::vector<SampledProfile>> out(jobs.size());
  for (size_t j = 0; j < jobs.size(); ++j)
    for (const ElementPlacement& p : jobs[j].placements)
      out[j].push_back(sample_placement(lum, p, jobs[j].sampling, jobs[j].complement_ideal, clip_level));
  return out;
}

namespace {
// Coarse elements' strips have flat bins to measure the noise in.
constexpr double kNoisePoolPxPerBar = 4.0;

// One noise model for the whole capture: the per-pixel noise belongs to the
// sensor, not to an element. Each strip fits var(level) = a + b level to
// the scatter along its bars (profile_sampler.h), but a fine element's bins
// are rarely flat (its bars' own slope inflates the scatter, up to 2x on
// simulated captures), so the coarse elements' models are pooled: each ok
// element's noise is the median of their predictions at its own mean level.
// Then its CNR (profiles/detectability.h). `given_pool`, when not empty,
// replaces the coarse strips (GradingContext::noise_pool).
void pool_noise(std::vector<ElementResult>& elements, size_t first, const std::vector<const SampledProfile*>& strips,
                const std::vector<const SampledProfile*>* given_pool, const CodeRounding& rounding) {
  std::vector<const SampledProfile*> pool;
  if (given_pool) pool = *given_pool;
  if (pool.empty())
    for (size_t i = first; i < elements.size(); ++i)
      if (elements[i].status == ElementStatus::ok && elements[i].px_per_bar >= kNoisePoolPxPerBar)
        pool.push_back(strips[i - first]);
  if (pool.empty())  // a chart photograph of fine groups only
    for (size_t i = first; i < elements.size(); ++i)
      if (elements[i].status == ElementStatus::ok) pool.push_back(strips[i - first]);
  if (pool.empty()) return;  // no ok element: nothing to give a CNR
  std::vector<std::pair<double, const SampledProfile*>> sd(pool.size());
  for (size_t i = first; i < elements.size(); ++i) {
    ElementResult& r = elements[i];
    if (r.status != ElementStatus::ok) continue;
    for (size_t k = 0; k < pool.size(); ++k) sd[k] = {pool[k]->noise_sd_at(r.mean_level), pool[k]};
    std::nth_element(sd.begin(), sd.begin() + sd.size() / 2, sd.end());
    const auto [noise_sd, median] = sd[sd.size() / 2];
    // A noise-free render has ~no scatter: the floors keep the CNR finite
    // and meaningful. The file's code rounding is noise it cannot be
    // without (noise-free 8-bit charts read noise_sd 7.5e-6, under 1 % of
    // their rounding's, and CNRs of 1e5 and more that only the rounding's
    // luck decided); the relative floor, a 16-bit code step of the level,
    // holds for float data and is the larger one for most 16-bit levels.
    r.noise_sd = std::max({noise_sd, 1.5e-5 * std::abs(r.mean_level), rounding.sd_at(r.mean_level)});
    r.noise_shot_fraction =
        std::clamp(median->noise_var_per_level * std::max(r.mean_level, 0.0) / (r.noise_sd * r.noise_sd), 0.0, 1.0);
    r.cnr = rose_cnr(r.signal, r.bar_pixels, r.noise_sd);
    // The signal carries m's relative error; a noise estimate from dof
    // degrees of freedom has 1 / sqrt(2 dof) (a chi-square).
    const double noise_rel = median->noise_dof > 0 ? 1 / std::sqrt(2 * median->noise_dof) : 0.5;
    r.cnr_sigma = r.cnr * std::hypot(r.m_sigma / std::max(r.m, 1e-9), noise_rel);
  }
}
}  // namespace

constexpr double kDipsPlacementChi2Ratio = 4;
constexpr double kDipsApartSigmas = 3;

bool placement_replaces(const ElementResult& alt, const ElementResult& r) {
  if (alt.m_from_dips != r.m_from_dips) {
    const ElementResult& fit = alt.m_from_dips ? r : alt;
    const ElementResult& dips = alt.m_from_dips ? alt : r;
    // An ok fit wins, unless the same model fits the other placement
    // several times better and the fit sees less of the bars than the
    // dips there: it sits off them (dev_14 turned by 5 degrees: G6E6 H
    // placed 0.46 period off fitted m 0.000 at chi^2 451, recentred its
    // gaps dip to m 0.43 at chi^2 47). A fit that reads the bars as well
    // keeps its place whatever the chi^2 (near the noise, 4 times is luck).
    const bool fit_placed_off = dips.chi2_reduced > 0 &&
                                fit.chi2_reduced > kDipsPlacementChi2Ratio * dips.chi2_reduced && fit.m < dips.m;
    const bool fit_wins = fit.status == ElementStatus::ok && !fit_placed_off;
    return alt.m_from_dips ? !fit_wins : fit_wins;
  }
  // Two fits: chi^2 compares different strips, where a strip beside the
  // bars fits their absence well. Where the gaps' model-free reading
  // (ElementResult::dips_m) of one placement lies clearly above the
  // other's, that one is on the bars and wins (dev_14 turned by 12
  // degrees: G6E6 H placed beside its bars fitted m 0.00 at chi^2 178,
  // its gaps reading 0.06 +- 0.02; centred on them, m 0.45 at chi^2 395,
  // its gaps 0.47 +- 0.07).
  // (Not transitive with the chi^2 order: grade_jobs keeps the first
  // placement against each other in turn, and jobs have two or three.)
  if (!alt.m_from_dips && !r.m_from_dips && alt.dips_m_sigma > 0 && r.dips_m_sigma > 0) {
    const double apart = (alt.dips_m - r.dips_m) / std::hypot(alt.dips_m_sigma, r.dips_m_sigma);
    if (std::abs(apart) > kDipsApartSigmas) return apart > 0;
  }
  return alt.chi2_reduced > 0 && (r.chi2_reduced <= 0 || alt.chi2_reduced < r.chi2_reduced);
}

double grade_jobs(const std::vector<ElementJob>& jobs, const std::vector<std::vector<SampledProfile>>& profiles,
                  const GradingContext& context, std::vector<ElementResult>& elements,
                  std::vector<size_t>* graded_placement) {
  const ReferenceResult& ref = context.reference;
  double fit_seconds = 0;
  // Warm start per orientation from the last good fit (coarse to fine).
  std::pair<double, double> last_lsf[2] = {{0, 0}, {0, 0}};
  const size_t first = elements.size();
  std::vector<const SampledProfile*> strips;  // the placement each element was graded on
  if (graded_placement) graded_placement->assign(jobs.size(), 0);
  for (size_t j = 0; j < jobs.size(); ++j) {
    const ElementJob& job = jobs[j];
    ElementResult r = job.element;
    // The step where the element is (gain_field.h): the patch's, unless the
    // light's direction changes over the target.
    const LevelStep step = ref.step_at(r.orientation, job.placements.front().strip.center_mm);
    std::pair<double, double>& warm = last_lsf[r.orientation == BarOrientation::vertical_bars];
    // A field's step is no scale only where it is consistent with zero
    // (within 2 sigma): elsewhere its error enters m_sigma (grade_element),
    // which grades the element on it. The patch's own step keeps its 5 sigma.
    const bool field = ref.field(r.orientation).plane;
    // A field's step also changes across the element's bars (u runs along x
    // across vertical bars, along y across horizontal ones): the bars shade
    // with its RMS over the triplet (detectability.h), which stays clear of
    // zero where the light's in-plane part changes sign inside the element.
    const GainField& gain = ref.field(r.orientation);
    const double slope_per_mm =
        !field ? 0.0 : r.orientation == BarOrientation::vertical_bars ? gain.gradient_x_per_mm : gain.gradient_y_per_mm;
    const LevelStep shading{rms_step_over_triplet(step.contrast, slope_per_mm, r.lp_per_mm), step.contrast_sigma};
    const bool no_scale = !shading.distinct_from_zero(field ? 2 : 5);
    if (no_scale) {
      // Nothing across this direction (a relief lit along these bars):
      // there is no scale to measure m against.
      const SampledProfile& sp = profiles[j].front();
      r.status = ElementStatus::low_signal;
      r.m_scale_undetermined = field;
      r.outline_px = sp.outline_px;
      r.outline_valid = sp.in_view;
      r.note = field
                   ? fmt::format("the shading gain across these bars is ~0 here (level step {:.3g} +- {:.3g} from "
                                 "the gain field, within 2 sigma of 0: the light runs along them): m cannot be scaled",
                                 step.contrast, step.contrast_sigma)
                   : "the reference patch shows no contrast across these bars (a relief lit along them?): m cannot "
                     "be scaled";
      elements.push_back(r);
      strips.push_back(&profiles[j].front());
      continue;
    }
    ProfileFitOptions fo;
    fo.signature = ref.signature;
    fo.fit_contrast = false;
    fo.contrast = step.contrast;
    fo.contrast_slope_per_mm = slope_per_mm;
    fo.fit_shape = context.options.fit_psf_shape;
    const std::pair<double, double> warm_before = warm;
    const ElementResult ungraded = r;  // each placement is graded from scratch
    const SampledProfile* graded_on = &profiles[j].front();
    fit_seconds += grade_element(r, profiles[j].front(), fo, step.contrast_sigma, context.options, warm, job.prepare,
                                 context.model_mismatch, context.read_gap_dips);
    // Another placement replaces the first where placement_replaces says so.
    for (size_t k = 1; k < profiles[j].size(); ++k) {
      if (!profiles[j][k].in_view) continue;
      ElementResult alt = ungraded;
      std::pair<double, double> alt_warm = warm_before;
      fit_seconds += grade_element(alt, profiles[j][k], fo, step.contrast_sigma, context.options, alt_warm,
                                   job.prepare, context.model_mismatch, context.read_gap_dips);
      if (placement_replaces(alt, r)) {
        r = alt;
        warm = alt_warm;
        graded_on = &profiles[j][k];
        if (graded_placement) (*graded_placement)[j] = k;
      }
    }
    elements.push_back(r);
    strips.push_back(graded_on);
  }
  pool_noise(elements, first, strips, context.noise_pool, context.rounding);
  return fit_seconds;
}

}  // namespace tactres
