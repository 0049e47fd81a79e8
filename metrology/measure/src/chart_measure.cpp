#include "tactres/measure/chart_measure.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <tuple>

#include "chart_frames.h"
#include "tactres/measure/element_pipeline.h"
#include "tactres/targets/usaf_series.h"
#include "tactres/util/stopwatch.h"

namespace tactres {

void ChartMeasureOptions::validate() const {
  measure.validate();
  detect.validate();
}

namespace {

using chart::PatternRef;

ProfileSamplingOptions sampling_for(const MeasureOptions& mo, double px_per_bar) {
  ProfileSamplingOptions so = mo.sampling;
  so.bin_px = std::max(so.bin_px, px_per_bar / mo.max_bins_per_bar);
  return so;
}

// Frames, centred on each pattern, then scaled by the profile model on the
// coarse patterns, smoothed over the chart (chart_frames.h).
std::vector<PatternFrame> pattern_frames(const ChartDetection& D, const std::vector<PatternRef>& refs,
                                         const chart::PlacementStore& store, const MeasureOptions& mo) {
  std::vector<PatternFrame> frames;
  std::vector<std::pair<Vec2, double>> scale_samples[2];  // [vertical bars]
  for (const PatternRef& r : refs) {
    const double px_per_bar = 0.5 * D.patterns[r.pattern].period_px;
    const PatternFrame detected = chart::frame_of(D.patterns[r.pattern], r.orientation, r.lp_per_mm);
    const ProfileSamplingOptions so = store.fitted_in_view(r, detected, sampling_for(mo, px_per_bar));
    const PatternFrame f = store.recentre(r, detected, so);
    frames.push_back(f);
    if (px_per_bar < 4) continue;
    const SampledProfile p = store.sample(r, f, so);
    if (!p.in_view) continue;
    ProfileFitOptions fo;
    fo.fit_contrast = true;
    fo.fit_shape = false;
    if (const auto a = chart::fit_scale(p.data, fo))
      scale_samples[r.orientation == BarOrientation::vertical_bars].push_back({f.center_px, f.px_per_mm * *a});
  }
  chart::ScaleField field[2] = {chart::fit_scale_field(scale_samples[0]), chart::fit_scale_field(scale_samples[1])};
  if (!field[0].valid) field[0] = field[1];
  if (!field[1].valid) field[1] = field[0];
  for (size_t i = 0; i < refs.size(); ++i) {
    const chart::ScaleField& s = field[refs[i].orientation == BarOrientation::vertical_bars];
    if (s.valid) frames[i].px_per_mm = s.at(frames[i].center_px);
  }
  return frames;
}

// One job per pattern: its final frame (recentred at the smoothed scale)
// and, where the correlation centring moved the frame by more than a tenth
// of a bar, the detected centre as a second placement. On faint, barely
// sampled patterns (~3 px per bar, m ~ 0.1) the correlation can lock half
// a bar off while the binarised bars' centroid was right, and a misplaced
// pattern reads as blur: the pipeline keeps whichever the model fits better.
std::vector<ElementJob> pattern_jobs(const ChartDetection& D, const std::vector<PatternRef>& refs,
                                     const std::vector<PatternFrame>& frames, chart::PlacementStore& store,
                                     const MeasureOptions& mo) {
  std::vector<ElementJob> jobs;
  for (size_t i = 0; i < refs.size(); ++i) {
    const PatternRef& r = refs[i];
    const BarPattern& pattern = D.patterns[r.pattern];
    ElementJob job;
    ElementResult& e = job.element;
    e = ElementResult::of(r.group, r.element, r.orientation, r.lp_per_mm, r.bar_width_mm() * frames[i].px_per_mm);
    job.sampling = store.fitted_in_view(r, frames[i], sampling_for(mo, e.px_per_bar));
    job.complement_ideal = D.light_bars;
    const PatternFrame f = store.recentre(r, frames[i], job.sampling);
    e.px_per_bar = r.bar_width_mm() * f.px_per_mm;
    job.placements.push_back(store.place(r, f, job.sampling));
    PatternFrame detected = f;
    detected.center_px = pattern.center_px;
    if (!pattern.predicted && norm(detected.center_px - f.center_px) > 0.1 * e.px_per_bar)
      job.placements.push_back(store.place(r, detected, job.sampling));
    // A predicted pattern is placed by its column, more precisely than its
    // faint bars could place it; a found one is centred on its data.
    if (!pattern.predicted)
      job.prepare = [w = r.bar_width_mm()](const ProfileData& d, const ProfileFitOptions& o) {
        return chart::refine_shift_by_fit(d, o, w);
      };
    jobs.push_back(std::move(job));
  }
  return jobs;
}

// The level step per orientation (what the reference patch is in layout
// mode): the median of the three coarsest elements that allow it, fitted
// with free contrast, so that one odd pattern (a mismatch, dust on a bar)
// does not scale every other. One orientation missing: the other's stands
// in (a printed chart has one ink density). False if neither has one.
bool chart_level_steps(const ChartDetection& D, const std::vector<PatternRef>& refs, const std::vector<ElementJob>& jobs,
                       const std::vector<std::vector<SampledProfile>>& profiles, const MeasureOptions& mo,
                       ReferenceResult& ref) {
  ref.signature = Signature::albedo;
  std::vector<ProfileFit> fits[2];  // [vertical bars]
  for (size_t i = 0; i < jobs.size(); ++i) {
    const ElementResult& e = jobs[i].element;
    std::vector<ProfileFit>& f = fits[e.orientation == BarOrientation::vertical_bars];
    const SampledProfile& p = profiles[i].front();
    if (f.size() >= 3 || e.px_per_bar < 3) continue;
    if (D.patterns[refs[i].pattern].predicted || !p.in_view || p.pixels_clipped > p.pixels_used / 50) continue;
    ProfileFitOptions fo;
    fo.fit_contrast = true;
    fo.fit_shape = mo.fit_psf_shape;  // a fixed Gaussian would put a heavy-tailed PSF's low-frequency loss into the level step
    const ProfileFit fit = fit_profile(p.data, fo);
    if (fit.usable && std::abs(fit.contrast) > 5 * fit.contrast_sigma) f.push_back(fit);
  }
  for (int vertical = 0; vertical < 2; ++vertical) {
    std::vector<ProfileFit>& f = fits[vertical];
    if (f.empty()) continue;
    std::sort(f.begin(), f.end(), [](const ProfileFit& a, const ProfileFit& b) { return a.contrast < b.contrast; });
    const ProfileFit& med = f[f.size() / 2];
    ref.step(vertical ? BarOrientation::vertical_bars : BarOrientation::horizontal_bars) = {
        med.contrast, med.contrast_sigma, med.chi2_reduced};
  }
  const bool have_h = !fits[0].empty(), have_v = !fits[1].empty();
  if (!have_h && !have_v) return false;
  if (!have_h) ref.horizontal_bars = {ref.vertical_bars.contrast, ref.vertical_bars.contrast_sigma, 0};
  if (!have_v) ref.vertical_bars = {ref.horizontal_bars.contrast, ref.horizontal_bars.contrast_sigma, 0};
  ref.usable = true;
  return true;
}

// Elements of which only one pattern was found: a status, not a guess
// (ChartElement::partial). They were not measured, so they take no part in
// the limits and are never resolved.
void add_partial_elements(const ChartDetection& D, Measurement& M) {
  for (const ChartElement& ce : D.partial) {
    for (BarOrientation o : {BarOrientation::horizontal_bars, BarOrientation::vertical_bars}) {
      ElementResult e = ElementResult::of(ce.group, ce.element, o, usaf_lp_per_mm(ce.group, ce.element), 0.5 * ce.period_px);
      e.status = ce.partial == ChartElement::Partial::partner_out_of_view ? ElementStatus::out_of_view
                                                                          : ElementStatus::fit_failed;
      M.elements.push_back(e);
    }
  }
  std::stable_sort(M.elements.begin(), M.elements.end(), [](const ElementResult& a, const ElementResult& b) {
    return std::tuple(a.group, a.element) < std::tuple(b.group, b.element);
  });
}

}  // namespace

ChartMeasurement measure_chart(const LoadedImage& image, const ChartMeasureOptions& options) {
  options.validate();
  Stopwatch t;
  ChartDetection detection = detect_chart(image.luminance, options.detect);
  const double detect_seconds = t.seconds();
  ChartMeasurement out = measure_chart_detected(image, std::move(detection), options);
  out.measurement.stage_seconds.insert(out.measurement.stage_seconds.begin(), {"detect_chart", detect_seconds});
  return out;
}

ChartMeasurement measure_chart_detected(const LoadedImage& image, ChartDetection detection,
                                        const ChartMeasureOptions& options) {
  options.validate();
  const MeasureOptions& mo = options.measure;
  ChartMeasurement out;
  out.detection = std::move(detection);
  Measurement& M = out.measurement;
  M.image_width = image.width;
  M.image_height = image.height;
  M.camera_source = "none: chart mode, each pattern in its own frame from the detection";
  M.distortion_corrected = false;
  M.transfer = image.transfer;
  const cv::Mat& lum = image.luminance;
  const ChartDetection& D = out.detection;
  if (!D.found) {
    M.problem = D.problem;
    return out;
  }

  Stopwatch t;
  std::vector<PatternRef> refs;
  for (const ChartElement& e : D.elements) {
    const double f = usaf_lp_per_mm(e.group, e.element);
    refs.push_back({e.h, BarOrientation::horizontal_bars, e.group, e.element, f});
    refs.push_back({e.v, BarOrientation::vertical_bars, e.group, e.element, f});
  }
  chart::PlacementStore store(lum, D, image.saturation_level);
  const std::vector<PatternFrame> frames = pattern_frames(D, refs, store, mo);
  const std::vector<ElementJob> jobs = pattern_jobs(D, refs, frames, store, mo);
  const auto profiles = sample_jobs(lum, jobs, image.saturation_level);
  M.stage_seconds.push_back({"frames", t.seconds()});

  t.restart();
  const bool scaled = chart_level_steps(D, refs, jobs, profiles, mo, M.reference);
  M.stage_seconds.push_back({"reference_patch", t.seconds()});
  if (!scaled) {
    M.problem =
        "the chart's level step cannot be measured: no element in full view has 3 or more pixels per bar with "
        "visible bars; frame a coarser group or bring the chart into focus";
    return out;
  }
  // Nyquist at the chart plane, from the largest element's scale.
  M.nyquist_h_lp_per_mm = 0.5 * frames[0].px_per_mm;
  M.nyquist_v_lp_per_mm = 0.5 * frames[1].px_per_mm;

  M.stage_seconds.push_back({"fits", grade_jobs(jobs, profiles, {M.reference, mo, false}, M.elements)});

  t.restart();
  // The limit runs over the elements in view: a chart photograph frames
  // some groups and cuts others, and a cut coarse element says nothing
  // about the finer ones (layout mode, which frames the whole target,
  // counts it as unresolved instead).
  decide_limits(M, mo.criterion, mo.detectability, true);
  add_partial_elements(D, M);
  M.stage_seconds.push_back({"decide", t.seconds()});
  M.usable = true;
  // A chart in which nothing is resolved cannot be measured: the JSON
  // still shows the coarsest element found as unresolved.
  if (!M.horizontal.any_resolved && !M.vertical.any_resolved) {
    M.usable = false;
    M.problem =
        "nothing on the chart is resolved: even the coarsest element found is below the criterion; bring the "
        "chart into focus or frame coarser groups";
  }
  return out;
}

}  // namespace tactres
