#include "tactres/measure/chart_measure.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <tuple>

#include <fmt/format.h>

#include "chart_frames.h"
#include "chart_jobs.h"
#include "chart_level_step.h"
#include "chart_motion.h"
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
using chart::ShiftLog;

// The missing pattern of each element of which only one was found
// (ChartElement::partial): a status, not a guess, so it is never resolved
// and the limit runs across it (`out_of_view` or `fit_failed`: unmeasured).
// The found pattern was measured with the rest. Then every element in
// series order, as the limits read them.
void add_missing_patterns(const ChartDetection& D, Measurement& M) {
  for (const ChartElement& ce : D.partial) {
    const BarOrientation o = ce.h >= 0 ? BarOrientation::vertical_bars : BarOrientation::horizontal_bars;
    ElementResult e = ElementResult::of(ce.group, ce.element, o, usaf_lp_per_mm(ce.group, ce.element), 0.5 * ce.period_px);
    e.status = ce.partial == ChartElement::Partial::partner_out_of_view ? ElementStatus::out_of_view
                                                                        : ElementStatus::fit_failed;
    e.note = ce.partial_reason;
    M.elements.push_back(e);
  }
  std::stable_sort(M.elements.begin(), M.elements.end(), [](const ElementResult& a, const ElementResult& b) {
    return std::tuple(a.group, a.element) < std::tuple(b.group, b.element);
  });
}

// Nyquist at the chart plane, from the largest element's scale (its H and
// V patterns come first; a single-pattern detection has one): the
// camera's, or a fibre bundle's, whose rows of cores sample the chart
// (grade_beyond_fibre_sampling), with a warning that says so.
void set_nyquist(const std::vector<PatternFrame>& frames, const ChartDetection& D, Measurement& M) {
  const double sampling_px = std::max(1.0, D.fibre_lattice_pitch_px);
  M.nyquist_h_lp_per_mm = 0.5 * frames.front().px_per_mm / sampling_px;
  M.nyquist_v_lp_per_mm = 0.5 * frames[std::min<size_t>(1, frames.size() - 1)].px_per_mm / sampling_px;
  if (D.fibre_lattice_pitch_px > 0)
    M.warnings.push_back(fmt::format(
        "a fibre bundle's honeycomb is over the image (rows of cores {:.2f} px apart): the chart was found on a "
        "copy smoothed at that scale and measured on the image itself; elements with fewer px per bar are "
        "aliased, and Nyquist is the bundle's",
        D.fibre_lattice_pitch_px));
}

void start_measurement(const LoadedImage& image, Measurement& M) {
  M.image_width = image.width;
  M.image_height = image.height;
  M.camera_source = "none: chart mode, each pattern in its own frame from the detection";
  M.distortion_corrected = false;
  M.transfer = image.transfer;
}

// A coherent fibre bundle (ChartDetection::fibre_lattice_pitch_px) samples
// the chart at its cores: bars narrower than the cores' row pitch are
// beyond its Nyquist limit, whatever the camera behind it resolves, and
// any modulation they show is the lattice's beat, not bars (dev_01: G7E4
// at 4.5 px per bar under rows 4.6 px apart fits m = 0.32 +- 0.15, where
// the eye sees only the honeycomb). Such elements are `aliased`, their m
// unread. (A hexagonal lattice samples up to 2/sqrt(3) as finely along
// some directions: this limit is the conservative one, the same for both
// orientations at any turn.)
void grade_beyond_fibre_sampling(const ChartDetection& D, Measurement& M) {
  const double pitch_px = D.fibre_lattice_pitch_px;
  if (pitch_px <= 0) return;
  for (ElementResult& e : M.elements)
    if (e.status == ElementStatus::ok && e.px_per_bar < pitch_px) {
      e.status = ElementStatus::aliased;
      e.m = e.m_sigma = 0;
      e.dips_m = e.dips_m_sigma = 0;
      e.note = fmt::format("{:.2f} px per bar is finer than the fibre bundle's rows of cores ({:.2f} px apart), "
                           "which sample the chart: beyond the bundle's Nyquist limit",
                           e.px_per_bar, pitch_px);
    }
}

// The missing patterns of the partial elements, then the limits from all
// elements in series order, and whether anything is resolved at all.
void decide_chart(const ChartDetection& D, const MeasureOptions& mo, Measurement& M) {
  Stopwatch t;
  // The limit runs over the elements in view: a chart photograph frames
  // some groups and cuts others, and a cut coarse element says nothing
  // about the finer ones (layout mode, which frames the whole target,
  // counts it as unresolved instead).
  add_missing_patterns(D, M);
  grade_beyond_fibre_sampling(D, M);
  grade_damaged(M, mo.criterion);
  decide_limits(M, mo.criterion, mo.detectability, true);
  M.stage_seconds.push_back({"decide", t.seconds()});
  M.usable = true;
  // A chart in which nothing is resolved cannot be measured: the JSON
  // still shows the coarsest element found as unresolved.
  if (!M.horizontal.any_resolved && !M.vertical.any_resolved) {
    M.usable = false;
    M.problem = unresolved_chart_problem(M.elements);
  }
}

// ---------------------------------------------------------------------------
// Live tracking (chart_measure.h, ChartTrack).

// Anchors: patterns with at least this many pixels per bar (where the
// scale field is measured too) and at least this modulation on the refit:
// their edges place them to a few hundredths of a pixel.
constexpr double kAnchorMinPxPerBar = 4.0;
constexpr double kAnchorMinM = 0.3;
// Per orientation, spread over the candidates from fine to coarse: fine
// ones cost little to sample and sit near the fine groups; coarse ones
// follow a larger jump.
constexpr size_t kAnchorsPerOrientation = 6;
// Anchor profiles are binned at most this fine (px), whatever the
// element's own bins: the match needs the edges' shape, not a bar's
// worth of pixels per bin.
constexpr double kAnchorBinPx = 0.5;
// An anchor's strip runs at most this far along its bars on each side of
// its centre (px): sixteen pixel rows across three edges place it to a few
// hundredths of a pixel, and a coarse pattern's full strip costs tens of
// thousands of pixels per frame.
constexpr double kAnchorHalfLengthPx = 8.0;
// An anchor's profile is matched within this many of its bar widths: the
// pattern repeats at two, and the coarse anchors, matched first, bring the
// fine ones within their reach.
constexpr double kAnchorReachBarWidths = 0.9;
// The motion must explain every anchor to this (the worst is dropped
// otherwise) and all of them together to the RMS below, or the frame is
// measured from scratch: a fine pattern's centre is only as good as this.
constexpr double kMotionOutlierPx = 0.3;
constexpr double kMotionMaxRmsPx = 0.1;

// The shift search's choice for one profile (0 when none ran: a predicted
// pattern, or a profile out of view).
double logged_shift_mm(const ShiftLog& log, const ProfileData* d) {
  for (const auto& [profile, shift_mm] : log)
    if (profile == d) return shift_mm;
  return 0;
}

ProfileSamplingOptions anchor_sampling(ProfileSamplingOptions so) {
  so.bin_px = std::min(so.bin_px, kAnchorBinPx);
  return so;
}

// Anchor pattern `i` of the track sampled where `motion` puts it.
SampledProfile sample_anchor(const LoadedImage& image, const ChartTrack& T, size_t i, const ChartMotion& motion,
                             PatternFrame& frame) {
  const ChartTrack::Pattern& p = T.patterns[i];
  frame = motion.apply(p.frame, T.elements[i].orientation);
  Strip strip = p.strip;
  strip.half_v_mm = std::min(strip.half_v_mm, kAnchorHalfLengthPx / p.frame.px_per_mm);
  return sample_placement(image.luminance, {&frame, p.artwork.get(), strip}, anchor_sampling(p.sampling),
                          T.detection.light_bars, image.saturation_level);
}

// Marks the anchors among the track's patterns (per orientation the
// candidates sorted by pixels per bar, kAnchorsPerOrientation of them
// evenly spread over that list) and keeps their profiles on the refit.
void choose_anchors(const LoadedImage& image, const std::vector<size_t>& candidates, ChartTrack& T) {
  const std::vector<ElementResult>& elements = T.elements;
  for (const BarOrientation o : {BarOrientation::horizontal_bars, BarOrientation::vertical_bars}) {
    std::vector<size_t> c;
    for (size_t i : candidates)
      if (elements[i].orientation == o) c.push_back(i);
    std::sort(c.begin(), c.end(), [&](size_t a, size_t b) { return elements[a].px_per_bar < elements[b].px_per_bar; });
    const size_t n = std::min(c.size(), kAnchorsPerOrientation);
    for (size_t k = 0; k < n; ++k) {
      const size_t i = c[n > 1 ? k * (c.size() - 1) / (n - 1) : 0];
      PatternFrame frame;
      const SampledProfile sp = sample_anchor(image, T, i, {}, frame);
      T.patterns[i].anchor_levels = chart::level_profile(sp.data);
      T.patterns[i].anchor = sp.in_view;
    }
  }
}

// The bars' direction over the chart, per orientation, from the anchor
// candidates, whose long, well-modulated bars place it to a small fraction
// of a degree: a fine pattern's own detected direction can be off by a
// degree or more, which tilts its strip against its bars, smears their
// edges and reads m several percent low near the limit, differently on
// every detection. The angle is a plane field over the image (mild
// perspective turns the bars smoothly); each frame keeps its sign.
void smooth_directions(const std::vector<size_t>& candidates, ChartTrack& T) {
  constexpr size_t kMinSamples = 3;
  for (const BarOrientation o : {BarOrientation::horizontal_bars, BarOrientation::vertical_bars}) {
    std::vector<std::pair<Vec2, double>> samples;
    double angle0_rad = 0;
    for (size_t i : candidates) {
      if (T.elements[i].orientation != o) continue;
      const PatternFrame& f = T.patterns[i].frame;
      const double a = std::atan2(f.x_dir.y, f.x_dir.x);
      if (samples.empty()) angle0_rad = a;
      // Bars have no head: fold the difference into (-pi/2, pi/2].
      const double d = a - angle0_rad - M_PI * std::round((a - angle0_rad) / M_PI);
      samples.push_back({f.center_px, d});
    }
    if (samples.size() < kMinSamples) continue;
    const chart::PlaneField field = chart::fit_plane_field(samples);
    for (size_t i = 0; i < T.patterns.size(); ++i) {
      if (T.elements[i].orientation != o) continue;
      PatternFrame& f = T.patterns[i].frame;
      const double a = angle0_rad + field.at(f.center_px);
      const Vec2 d{std::cos(a), std::sin(a)};
      f.x_dir = dot(d, f.x_dir) < 0 ? -1.0 * d : d;
    }
  }
}

// What a refit established, for the frames after it: each pattern's frame
// (the placement it was graded on) and the shift its fit chose there, its
// artwork and strip; the level steps; the graded elements (measurement
// order, before the partial elements' missing patterns join them). A
// partial element's lone pattern is tracked but never an anchor.
ChartTrack make_track(const LoadedImage& image, const ChartDetection& D, const std::vector<PatternRef>& refs,
                      const std::vector<ElementJob>& jobs, const std::vector<std::vector<SampledProfile>>& profiles,
                      const std::vector<size_t>& graded, const ShiftLog& shifts, const chart::PlacementStore& store,
                      const Measurement& M) {
  ChartTrack T;
  T.detection = D;
  T.reference = M.reference;
  T.elements = M.elements;
  std::vector<size_t> candidates;
  for (size_t j = 0; j < jobs.size(); ++j) {
    const size_t k = graded[j];
    const ElementPlacement& placed = jobs[j].placements[k];
    ChartTrack::Pattern& p = T.patterns.emplace_back();
    // Chart mode places every pattern through its own PatternFrame.
    p.frame = static_cast<const PatternFrame&>(*placed.plane);
    p.fit_shift_mm = logged_shift_mm(shifts, &profiles[j][k].data);
    p.artwork = store.shared_artwork(placed.artwork);
    p.strip = placed.strip;
    p.sampling = jobs[j].sampling;
    const ElementResult& e = M.elements[j];
    // Not under a fibre bundle's rows (two pitches per bar and more): the
    // honeycomb stays with the camera, and finer bars would track it.
    if (!D.patterns[refs[j].pattern].predicted && !refs[j].lone && e.status == ElementStatus::ok && e.m >= kAnchorMinM &&
        e.px_per_bar >= std::max(kAnchorMinPxPerBar, 2 * D.fibre_lattice_pitch_px))
      candidates.push_back(j);
  }
  smooth_directions(candidates, T);
  choose_anchors(image, candidates, T);
  return T;
}

// How the chart moved since the refit. The anchors are matched coarse to
// fine: the coarse half where the last frame's motion puts them (they
// reach furthest), the fine half where those say. Their profiles go to
// `anchor_profiles` (coarse strips, for the noise pool).
chart::MotionFit track_motion(const LoadedImage& image, const ChartTrack& T,
                              std::vector<SampledProfile>& anchor_profiles) {
  std::vector<size_t> order;
  for (size_t i = 0; i < T.patterns.size(); ++i)
    if (T.patterns[i].anchor) order.push_back(i);
  std::sort(order.begin(), order.end(),
            [&](size_t a, size_t b) { return T.elements[a].px_per_bar > T.elements[b].px_per_bar; });
  std::vector<chart::MotionSample> samples;
  ChartMotion predicted = T.motion;
  for (size_t k = 0; k < order.size(); ++k) {
    if (k == (order.size() + 1) / 2)
      if (const chart::MotionFit coarse = chart::fit_chart_motion(samples, kMotionOutlierPx); coarse.ok)
        predicted = coarse.motion;
    const size_t i = order[k];
    PatternFrame f;
    SampledProfile sp = sample_anchor(image, T, i, predicted, f);
    if (!sp.in_view) continue;
    const double reach_mm = kAnchorReachBarWidths * 0.5 / T.elements[i].lp_per_mm;
    const auto shift_mm = chart::match_shift_mm(chart::level_profile(sp.data), T.patterns[i].anchor_levels, reach_mm);
    if (!shift_mm) continue;
    const Vec2 across = chart::across_dir(f, T.elements[i].orientation);
    samples.push_back({T.patterns[i].frame.center_px, across, dot(across, f.center_px) + *shift_mm * f.px_per_mm});
    anchor_profiles.push_back(std::move(sp));
  }
  chart::MotionFit fit = chart::fit_chart_motion(std::move(samples), kMotionOutlierPx);
  fit.ok = fit.ok && fit.rms_px <= kMotionMaxRmsPx;
  return fit;
}

// The detection moved with the chart (for the overlay and the caller).
ChartDetection moved_detection(const ChartDetection& D, const ChartMotion& motion) {
  ChartDetection out = D;
  for (BarPattern& p : out.patterns) {
    p.center_px = motion.apply(p.center_px);
    const Vec2 d = motion.apply_linear(p.bar_dir);
    p.bar_dir = (1.0 / norm(d)) * d;
    for (Vec2& c : p.bar_centers_px) c = motion.apply(c);
  }
  return out;
}

// A tracked frame (ChartFramePlan with a track): the refit's patterns moved
// with the chart, each element the plan accepts fitted once, the others
// carried.
ChartFrameResult measure_tracked(const LoadedImage& image, const ChartMeasureOptions& options,
                                 const ChartFramePlan& plan) {
  const ChartTrack& T = *plan.track;
  const MeasureOptions& mo = options.measure;
  ChartFrameResult out;
  out.tracked = true;
  Measurement& M = out.measurement.measurement;
  start_measurement(image, M);
  Stopwatch t;
  std::vector<SampledProfile> anchor_profiles;
  const chart::MotionFit motion = track_motion(image, T, anchor_profiles);
  M.stage_seconds.push_back({"track_motion", t.seconds()});
  if (!motion.ok) {
    M.problem = "the chart moved too far since the frame before to be tracked: measure this frame from scratch";
    return out;
  }
  out.measurement.detection = moved_detection(T.detection, motion.motion);

  t.restart();
  std::vector<PatternFrame> frames(T.patterns.size());  // sized once: the jobs point into it
  std::vector<ElementJob> jobs;
  std::vector<size_t> index;  // the pattern of each job
  for (size_t i = 0; i < T.patterns.size(); ++i) {
    const ChartTrack::Pattern& p = T.patterns[i];
    const ElementResult& last = T.elements[i];
    frames[i] = motion.motion.apply(p.frame, last.orientation);
    if (plan.fit_element && !plan.fit_element(last)) continue;
    ElementJob job;
    job.element = ElementResult::of(last.group, last.element, last.orientation, last.lp_per_mm,
                                    0.5 / last.lp_per_mm * frames[i].px_per_mm);
    job.placements.push_back({&frames[i], p.artwork.get(), p.strip});
    job.sampling = p.sampling;
    job.complement_ideal = T.detection.light_bars;
    // Where the refit's fit centred the pattern in this frame (the profile
    // is sampled on the frame as the refit sampled it: the fit depends a
    // little on where the bins and the window fall).
    if (p.fit_shift_mm != 0)
      job.prepare = [shift_mm = p.fit_shift_mm](const ProfileData& d, const ProfileFitOptions&) {
        return chart::shifted_ideal(d, shift_mm);
      };
    jobs.push_back(std::move(job));
    index.push_back(i);
  }
  const auto profiles = sample_jobs(image.luminance, jobs, image.saturation_level);
  M.stage_seconds.push_back({"frames", t.seconds()});

  M.reference = T.reference;
  std::vector<const SampledProfile*> pool;
  for (const SampledProfile& sp : anchor_profiles) pool.push_back(&sp);
  // Fitting every element pools the coarse ones' noise as a refit does;
  // fitting a few near the limit takes the anchors' coarse strips instead.
  const GradingContext context{M.reference, mo, false, true, plan.fit_element ? &pool : nullptr, image.rounding};
  std::vector<ElementResult> fitted;
  M.stage_seconds.push_back({"fits", grade_jobs(jobs, profiles, context, fitted)});
  M.elements = T.elements;
  for (size_t k = 0; k < fitted.size(); ++k) M.elements[index[k]] = fitted[k];
  set_nyquist(frames, T.detection, M);

  ChartTrack next = T;
  next.motion = motion.motion;
  next.elements = M.elements;
  decide_chart(T.detection, mo, M);
  if (M.usable && ((M.horizontal.beyond_finest && !T.refit_beyond_finest_h) ||
                   (M.vertical.beyond_finest && !T.refit_beyond_finest_v))) {
    M.usable = false;
    M.problem = "the limit runs past the finest element the chart's detection found: detect the chart again";
  }
  if (M.usable) out.track = std::move(next);
  return out;
}

// measure_chart_detected, and the track a live sequence carries from it
// when `track` is given.
ChartMeasurement measure_detected(const LoadedImage& image, ChartDetection detection,
                                  const ChartMeasureOptions& options, std::optional<ChartTrack>* track) {
  options.validate();
  const MeasureOptions& mo = options.measure;
  ChartMeasurement out;
  out.detection = std::move(detection);
  Measurement& M = out.measurement;
  start_measurement(image, M);
  const cv::Mat& lum = image.luminance;
  const ChartDetection& D = out.detection;
  if (!D.found) {
    M.problem = D.problem;
    return out;
  }

  Stopwatch t;
  // The patterns found: both of each element (one for a single-pattern
  // detection, chart_detect.h), then the one of each partial element.
  std::vector<PatternRef> refs;
  auto add_refs = [&](const ChartElement& e, bool lone) {
    const double f = usaf_lp_per_mm(e.group, e.element);
    if (e.h >= 0) refs.push_back({e.h, BarOrientation::horizontal_bars, e.group, e.element, f, lone});
    if (e.v >= 0) refs.push_back({e.v, BarOrientation::vertical_bars, e.group, e.element, f, lone});
  };
  // An element whose missing pattern was placed beside the found one
  // (ChartDetection::partners_placed), or found apart from it
  // (ChartElement::partner_joined), is lone like a partial one: no
  // partner paired confirms its index, so neither pattern joins the scale
  // field, the level step or the tracking anchors.
  for (const ChartElement& e : D.elements) add_refs(e, index_from_one_pattern(D, e));
  for (const ChartElement& e : D.partial) add_refs(e, true);
  chart::PlacementStore store(lum, D, image.saturation_level);
  ShiftLog shifts;
  std::vector<PatternFrame> frames = chart::pattern_frames(D, refs, store, mo);
  chart::shift_predicted_groups(D, refs, frames, store, mo);
  std::vector<ElementJob> jobs = chart::pattern_jobs(D, refs, frames, store, mo, &shifts);
  auto profiles = sample_jobs(lum, jobs, image.saturation_level);
  M.stage_seconds.push_back({"frames", t.seconds()});

  t.restart();
  std::string step_note;
  const bool scaled = chart::chart_level_steps(D, refs, jobs, profiles, mo, M.reference, &step_note);
  M.stage_seconds.push_back({"reference_patch", t.seconds()});
  set_nyquist(frames, D, M);
  if (!D.anchor_conflict.empty()) M.warnings.push_back(D.anchor_conflict);
  if (!scaled) {
    // One pattern and nothing else of a chart is what a single element
    // filling a microscope frame looks like, and what three strokes of a
    // graphic can look like (a plot, drawn in clipped black): the message
    // must not only speak of exposure there.
    M.problem = D.single_pattern ? step_note + "; this was the only three-bar pattern found, and nothing else of a "
                                               "chart: if the image shows no chart, it is not one"
                                 : step_note;
    return out;
  }
  if (!step_note.empty()) M.warnings.push_back(step_note);

  std::vector<size_t> graded;
  const GradingContext context{M.reference, mo, false, true, nullptr, image.rounding};
  // M.elements[j] is jobs[j]'s (make_track relies on it too).
  CV_Assert(M.elements.empty());
  double fit_seconds = grade_jobs(jobs, profiles, context, M.elements, &graded);
  // A triplet found a period off along its column shows a flat gap: where
  // it stands one period along, that place is graded too. Rare (none of
  // the real captures' patterns), so everything is sampled and graded
  // again rather than patched: the fits' warm starts and the shift log
  // stay those of one pass.
  if (chart::add_unslipped_placements(D, refs, jobs, store, M.elements, graded) > 0) {
    profiles = sample_jobs(lum, jobs, image.saturation_level);
    M.elements.clear();
    shifts.clear();  // keyed by the profiles just replaced
    fit_seconds += grade_jobs(jobs, profiles, context, M.elements, &graded);
  }
  M.stage_seconds.push_back({"fits", fit_seconds});
  if (track) *track = make_track(image, D, refs, jobs, profiles, graded, shifts, store, M);
  decide_chart(D, mo, M);
  if (track && M.usable) {
    (*track)->refit_beyond_finest_h = M.horizontal.beyond_finest;
    (*track)->refit_beyond_finest_v = M.vertical.beyond_finest;
  }
  if (track && !M.usable) track->reset();
  return out;
}

}  // namespace

PatternFrame ChartMotion::apply(const PatternFrame& f, BarOrientation bars) const {
  const Vec2 moved = apply_linear(chart::across_dir(f, bars));
  const double stretch = norm(moved);
  const Vec2 u = (1.0 / stretch) * moved;
  PatternFrame out = f;
  out.center_px = apply(f.center_px);
  out.px_per_mm = f.px_per_mm * stretch;
  // across_dir(out, bars) == u: x_dir itself for vertical bars; for
  // horizontal bars x_dir is u turned so that y_dir() is u.
  out.x_dir = bars == BarOrientation::vertical_bars ? u : Vec2{u.y, -u.x};
  return out;
}

namespace {

// detect_chart, then measure_detected; its time first among the stages.
ChartMeasurement detect_and_measure(const LoadedImage& image, const ChartMeasureOptions& options,
                                    std::optional<ChartTrack>* track) {
  options.validate();
  Stopwatch t;
  ChartDetection detection = detect_chart(image.luminance, options.detect);
  const double detect_seconds = t.seconds();
  ChartMeasurement out = measure_detected(image, std::move(detection), options, track);
  out.measurement.stage_seconds.insert(out.measurement.stage_seconds.begin(), {"detect_chart", detect_seconds});
  return out;
}

}  // namespace

ChartMeasurement measure_chart(const LoadedImage& image, const ChartMeasureOptions& options) {
  return detect_and_measure(image, options, nullptr);
}

ChartMeasurement measure_chart_detected(const LoadedImage& image, ChartDetection detection,
                                        const ChartMeasureOptions& options) {
  return measure_detected(image, std::move(detection), options, nullptr);
}

ChartFrameResult measure_chart_frame(const LoadedImage& image, const ChartMeasureOptions& options,
                                     const ChartFramePlan& plan) {
  if (plan.track) {
    options.validate();
    return measure_tracked(image, options, plan);
  }
  ChartFrameResult out;
  out.measurement = detect_and_measure(image, options, &out.track);
  return out;
}

}  // namespace tactres
