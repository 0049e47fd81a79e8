#include "tactres/measure/element_pipeline.h"

#include <utility>

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

double grade_jobs(const std::vector<ElementJob>& jobs, const std::vector<std::vector<SampledProfile>>& profiles,
                  const GradingContext& context, std::vector<ElementResult>& elements) {
  const ReferenceResult& ref = context.reference;
  double fit_seconds = 0;
  // Warm start per orientation from the last good fit (coarse to fine).
  std::pair<double, double> last_lsf[2] = {{0, 0}, {0, 0}};
  for (size_t j = 0; j < jobs.size(); ++j) {
    const ElementJob& job = jobs[j];
    ElementResult r = job.element;
    const LevelStep& step = ref.step(r.orientation);
    std::pair<double, double>& warm = last_lsf[r.orientation == BarOrientation::vertical_bars];
    if (!step.usable()) {
      // Nothing across this direction (a relief lit along these bars):
      // there is no scale to measure m against.
      const SampledProfile& sp = profiles[j].front();
      r.status = ElementStatus::low_signal;
      r.outline_px = sp.outline_px;
      r.outline_valid = sp.in_view;
      r.note = "the reference patch shows no contrast across these bars (a relief lit along them?): m cannot be "
               "scaled";
      elements.push_back(r);
      continue;
    }
    ProfileFitOptions fo;
    fo.signature = ref.signature;
    fo.fit_contrast = false;
    fo.contrast = step.contrast;
    fo.fit_shape = context.options.fit_psf_shape;
    const std::pair<double, double> warm_before = warm;
    fit_seconds += grade_element(r, profiles[j].front(), fo, step.contrast_sigma, context.options, warm, job.prepare,
                                 context.model_mismatch);
    // Another placement replaces the first only when the model fits it better.
    for (size_t k = 1; k < profiles[j].size(); ++k) {
      if (!profiles[j][k].in_view) continue;
      ElementResult alt = r;
      alt.m = alt.m_sigma = alt.beta = alt.chi2_reduced = 0;
      std::pair<double, double> alt_warm = warm_before;
      fit_seconds += grade_element(alt, profiles[j][k], fo, step.contrast_sigma, context.options, alt_warm,
                                   job.prepare, context.model_mismatch);
      const bool r_fitted = r.chi2_reduced > 0, alt_fitted = alt.chi2_reduced > 0;
      if (alt_fitted && (!r_fitted || alt.chi2_reduced < r.chi2_reduced)) {
        r = alt;
        warm = alt_warm;
      }
    }
    elements.push_back(r);
  }
  return fit_seconds;
}

}  // namespace tactres
