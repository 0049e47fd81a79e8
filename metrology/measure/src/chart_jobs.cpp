// The jobs of chart mode's element pipeline: where each pattern is
// measured (its frame: centre, direction, scale) and the placements its
// fit chooses between (chart_jobs.h).

#include "chart_jobs.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <utility>

namespace tactres::chart {

namespace {

ProfileSamplingOptions sampling_for(const MeasureOptions& mo, double px_per_bar) {
  ProfileSamplingOptions so = mo.sampling;
  so.bin_px = mo.bin_px_for(px_per_bar);
  return so;
}

}  // namespace

// Frames where each pattern was found, scaled by the profile model on the
// coarse patterns, smoothed over the chart (chart_frames.h); pattern_jobs
// centres them.
//
// The scale samples: per orientation the kScaleSamples coarsest patterns
// of at least 4 px per bar whose scale fit succeeds. A scale fit costs
// three profile fits (a fifth of chart mode when every coarse pattern took
// part); the coarsest pin the scale down best (its relative error falls
// with the bars' size in pixels), and on the chart they lie outermost,
// spanning the plane the field fits.
constexpr size_t kScaleSamples = 8;
std::vector<PatternFrame> pattern_frames(const ChartDetection& D, const std::vector<PatternRef>& refs,
                                         const PlacementStore& store, const MeasureOptions& mo) {
  std::vector<PatternFrame> frames;
  std::vector<size_t> coarse[2];  // [vertical bars]: indices into refs
  for (size_t i = 0; i < refs.size(); ++i) {
    const PatternRef& r = refs[i];
    frames.push_back(frame_of(D.patterns[r.pattern], r.orientation, r.lp_per_mm));
    if (0.5 * D.patterns[r.pattern].period_px >= 4 && !r.lone)
      coarse[r.orientation == BarOrientation::vertical_bars].push_back(i);
  }
  std::vector<std::pair<Vec2, double>> scale_samples[2];
  for (int o = 0; o < 2; ++o) {
    std::stable_sort(coarse[o].begin(), coarse[o].end(), [&](size_t a, size_t b) {
      return D.patterns[refs[a].pattern].period_px > D.patterns[refs[b].pattern].period_px;
    });
    for (size_t k = 0; k < coarse[o].size() && scale_samples[o].size() < kScaleSamples; ++k) {
      const size_t i = coarse[o][k];
      const double px_per_bar = 0.5 * D.patterns[refs[i].pattern].period_px;
      ProfileSamplingOptions so = store.fitted_in_view(refs[i], frames[i], sampling_for(mo, px_per_bar));
      // Centred first, its margin fitted again (pattern_jobs centres every
      // pattern at the field's scale).
      if (!D.patterns[refs[i].pattern].predicted) {
        frames[i] = store.recentre(refs[i], frames[i], so);
        so = store.fitted_in_view(refs[i], frames[i], so);
      }
      const SampledProfile p = store.sample(refs[i], frames[i], so);
      if (!p.in_view) continue;
      ProfileFitOptions fo;
      fo.fit_contrast = true;
      fo.fit_shape = false;
      if (const auto a = fit_scale(p.data, fo))
        scale_samples[o].push_back({frames[i].center_px, frames[i].px_per_mm * *a});
    }
  }
  ScaleField field[2] = {fit_scale_field(scale_samples[0]), fit_scale_field(scale_samples[1])};
  if (!field[0].valid) field[0] = field[1];
  if (!field[1].valid) field[1] = field[0];
  for (size_t i = 0; i < refs.size(); ++i) {
    const ScaleField& s = field[refs[i].orientation == BarOrientation::vertical_bars];
    if (s.valid) frames[i].px_per_mm = s.at_or(frames[i].center_px, frames[i].px_per_mm);
  }
  return frames;
}

// The patterns the nesting predicted (BarPattern::nested) for one group
// and orientation were placed together, a coarse group mapped as a whole,
// and a lens's distortion moves the copy as a whole: dev_03's group 7 H
// triplets (1.4-2.4 px per bar) lie 2 px off their prediction, 0.8-1.5 of
// their bars, beyond what centring each one reaches. A group of four or
// more such patterns is moved across its bars, each pattern by the shift
// the others share (shared_shifts_px, within 1.5 bars of the coarsest):
// one faint pattern could not place itself so far, but a shift that lines
// up the bars of several patterns of different periods at once is theirs.
// Fewer patterns could line up on noise. A column's predictions
// (BarPattern::predicted, not nested) are not moved together: their error
// grows along the column.
constexpr size_t kMinGroupPatterns = 4;
void shift_predicted_groups(const ChartDetection& D, const std::vector<PatternRef>& refs,
                            std::vector<PatternFrame>& frames, const PlacementStore& store,
                            const MeasureOptions& mo) {
  std::map<std::pair<int, BarOrientation>, std::vector<size_t>> groups;
  for (size_t i = 0; i < refs.size(); ++i)
    if (D.patterns[refs[i].pattern].nested && !refs[i].lone) groups[{refs[i].group, refs[i].orientation}].push_back(i);
  for (const auto& [key, members] : groups) {
    if (members.size() < kMinGroupPatterns) continue;
    std::vector<SampledProfile> profiles;
    std::vector<ShiftSample> samples;
    std::vector<size_t> sampled;  // the members with a sample, in its order
    double max_bar_px = 0;
    profiles.reserve(members.size());
    const Vec2 common = across_dir(frames[members[0]], refs[members[0]].orientation);
    for (const size_t i : members) {
      const double bar_px = refs[i].bar_width_mm() * frames[i].px_per_mm;
      max_bar_px = std::max(max_bar_px, bar_px);
      const ProfileSamplingOptions so = store.fitted_in_view(refs[i], frames[i], sampling_for(mo, bar_px));
      profiles.push_back(store.sample(refs[i], frames[i], so));
      if (!profiles.back().in_view) continue;
      const Vec2 dir = across_dir(frames[i], refs[i].orientation);
      samples.push_back({&profiles.back().data, refs[i].bar_width_mm(), dot(dir, common) / frames[i].px_per_mm});
      sampled.push_back(i);
    }
    if (samples.size() < kMinGroupPatterns) continue;
    const std::vector<std::optional<double>> shifts_px = shared_shifts_px(samples, D.light_bars, 1.5 * max_bar_px);
    for (size_t k = 0; k < sampled.size(); ++k)
      if (shifts_px[k]) frames[sampled[k]].center_px = frames[sampled[k]].center_px + *shifts_px[k] * common;
  }
}

// One job per pattern: its final frame (a found pattern's recentred at the
// smoothed scale; a predicted one's where its column or the nesting put
// it) and a second placement where it lies more than a tenth of a bar away,
// the pipeline keeping whichever the model fits better (a misplaced
// pattern reads as blur):
// - a found pattern: its detected centre. On faint, barely sampled
//   patterns (~3 px per bar, m ~ 0.1) the correlation can lock half a bar
//   off while the binarised bars' centroid was right.
// - a predicted pattern: the frame centred on its data. Its column or the
//   nesting places it first (a nested group then moved together by
//   shift_predicted_groups), but a lens's distortion moves each pattern a
//   little too: before the group's shift, dev_03's group 7 V triplets lay
//   a px (0.4 bar) off their nested prediction, where bars of m 0.7 read
//   m ~ 0.
//
// `shifts` records, per profile the shift search ran on, the shift it chose
// (mm along u): a live sequence's track keeps where each pattern's fit
// centred it.
std::vector<ElementJob> pattern_jobs(const ChartDetection& D, const std::vector<PatternRef>& refs,
                                     const std::vector<PatternFrame>& frames, PlacementStore& store,
                                     const MeasureOptions& mo, ShiftLog* shifts) {
  std::vector<ElementJob> jobs;
  for (size_t i = 0; i < refs.size(); ++i) {
    const PatternRef& r = refs[i];
    const BarPattern& pattern = D.patterns[r.pattern];
    ElementJob job;
    ElementResult& e = job.element;
    e = ElementResult::of(r.group, r.element, r.orientation, r.lp_per_mm, r.bar_width_mm() * frames[i].px_per_mm);
    job.sampling = store.fitted_in_view(r, frames[i], sampling_for(mo, e.px_per_bar));
    job.complement_ideal = D.light_bars;
    const PatternFrame f = pattern.predicted ? frames[i] : store.recentre(r, frames[i], job.sampling);
    // Recentring can move a strip that only just fitted out of the image
    // (a single element filling the frame): fit its margin again.
    job.sampling = store.fitted_in_view(r, f, job.sampling);
    e.px_per_bar = r.bar_width_mm() * f.px_per_mm;
    job.placements.push_back(store.place(r, f, job.sampling));
    PatternFrame second = f;
    if (pattern.predicted) second = store.recentre(r, f, job.sampling);
    else second.center_px = pattern.center_px;
    if (norm(second.center_px - f.center_px) > 0.1 * e.px_per_bar)
      job.placements.push_back(store.place(r, second, store.fitted_in_view(r, second, job.sampling)));
    // A found pattern's fit moves its bars within a quarter of a bar
    // (refine_shift_by_fit); a predicted one's does not, so that its faint
    // bars' noise cannot pull a fit onto them: only the correlation
    // centring above offers it a second place.
    if (!pattern.predicted)
      job.prepare = [w = r.bar_width_mm(), shifts](const ProfileData& d, const ProfileFitOptions& o) {
        double shift_mm = 0;
        ProfileData out = refine_shift_by_fit(d, o, w, &shift_mm);
        if (shifts) shifts->push_back({&d, shift_mm});
        return out;
      };
    jobs.push_back(std::move(job));
  }
  return jobs;
}

// A found pattern graded with one gap flat may be a triplet found one
// period off along its column (PlacementStore::unslipped); where the
// triplet stands one period along, that frame becomes another placement,
// and the pipeline keeps whichever the model fits better. Only there:
// elsewhere the check's wider strip is not sampled.
int add_unslipped_placements(const ChartDetection& D, const std::vector<PatternRef>& refs,
                             std::vector<ElementJob>& jobs, PlacementStore& store,
                             const std::vector<ElementResult>& graded, const std::vector<size_t>& graded_placement) {
  CV_Assert(graded.size() == jobs.size() && graded_placement.size() == jobs.size());
  int added = 0;
  for (size_t j = 0; j < jobs.size(); ++j) {
    const ElementResult& e = graded[j];
    if (e.status != ElementStatus::ok || !e.gap_flat || D.patterns[refs[j].pattern].predicted) continue;
    ElementJob& job = jobs[j];
    // Chart mode places every pattern through its own PatternFrame.
    const auto& f = static_cast<const PatternFrame&>(*job.placements[graded_placement[j]].plane);
    const std::optional<PatternFrame> there = store.unslipped(refs[j], f, job.sampling);
    if (!there) continue;
    job.placements.push_back(store.place(refs[j], *there, store.fitted_in_view(refs[j], *there, job.sampling)));
    ++added;
  }
  return added;
}

}  // namespace tactres::chart
