// The chart's level step (chart_level_step.h).

#include "chart_level_step.h"

#include "tactres/util/order_stats.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace tactres::chart {

namespace {

// 0 or 1 when the ideal holds that value over [u - r, u + r]; -1 otherwise.
int plateau_of(const ProfileData& d, double u_mm, double r_mm) {
  const double s0 = d.ideal_at(u_mm);
  if (!(s0 == 0 || s0 >= 0.999)) return -1;
  for (int k = -4; k <= 4; ++k)
    if (std::abs(d.ideal_at(u_mm + k * r_mm / 4) - s0) > 1e-3) return -1;
  return s0 == 0 ? 0 : 1;
}

LevelStep step_of(const ProfileFit& f) { return {f.contrast, f.contrast_sigma, f.chi2_reduced}; }

// A fitted step that stands out of its error.
bool fitted_step_usable(const ProfileFit& f) { return f.usable && std::abs(f.contrast) > 5 * f.contrast_sigma; }

// Pinned at the model's bound (c = -1: ink reflecting nothing), where a fit
// that cannot describe the edges also ends up.
bool at_bound(const ProfileFit& f) { return f.contrast <= -0.999; }

}  // namespace

std::optional<LevelStep> plateau_level_step(const ProfileData& d, double bar_width_mm) {
  const double r_mm = 0.25 * bar_width_mm;
  // Ground: least squares line B0 + B1 u through the ground plateaus.
  double n = 0, su = 0, sv = 0, suu = 0, suv = 0;
  int ground_runs = 0, last = -1;
  struct InkBin {
    double u, v;
    int bar;
  };
  std::vector<InkBin> ink;
  int bars = 0;
  for (int b = d.fit_begin; b < d.fit_end; ++b) {
    const double u = d.bin_center_mm(b), v = d.value[b];
    // A clipped bin's mean is only a bound on its level (ProfileData::bound).
    const int p = std::isfinite(v) && d.count[b] > 0 && d.bound_at(b) == 0 ? plateau_of(d, u, r_mm) : -1;
    if (p == 0) {
      ground_runs += last != 0;
      n += 1, su += u, sv += v, suu += u * u, suv += u * v;
    } else if (p == 1) {
      bars += last != 1;
      ink.push_back({u, v, bars - 1});
    }
    if (p >= 0) last = p;
  }
  if (ground_runs < 2 || bars < 2 || n < 2) return std::nullopt;
  const double det = n * suu - su * su;
  const double b1 = det > 0 ? (n * suv - su * sv) / det : 0;
  const double b0 = (sv - b1 * su) / n;
  std::vector<double> sum(bars, 0), count(bars, 0);
  const double mean_ground = sv / n;
  for (const InkBin& k : ink) {
    // The line is extrapolated at most across the triplet: a ground that
    // falls far below its mean there is a misfit, not light.
    const double ground = b0 + b1 * k.u;
    if (!(ground > 0.2 * mean_ground) || !(mean_ground > 0)) return std::nullopt;
    sum[k.bar] += k.v / ground;
    count[k.bar] += 1;
  }
  std::vector<double> ratios;
  for (int i = 0; i < bars; ++i) ratios.push_back(sum[i] / count[i]);
  const double mean = tactres::mean(ratios), sd = sample_sd(ratios);
  // One bar's ratio stands for all: at least 1 % of the step, so that three
  // bars that happen to agree do not claim more than a print achieves.
  const double sigma = std::max(sd / std::sqrt(double(bars)), 0.01 * std::abs(mean - 1));
  // Ink reflects no less than nothing: a step below -1 (or a non-finite
  // one) means the plateaus are not where the ideal says.
  if (!std::isfinite(mean) || !std::isfinite(sigma) || mean - 1 < -1.02) return std::nullopt;
  return LevelStep{mean - 1, sigma, 0};
}

namespace {

// Whether every bin of `d` that clipping left a bound is clipped at black,
// and on the dark side of the ideal (ideal 1: the ink, or a negative
// chart's chrome, the ideal being complemented there): the dark side
// reaches zero, and a fit that takes those bins as bounds
// (ProfileData::bound) still sees the light level it scales by. A bin
// clipped at saturation, or a bound at black on the light side, leaves
// that level unknown. (Most bins clipped at black are no bounds: their
// unclipped pixels fix their level, profiles/censored_level.h.)
bool clipped_at_black_only(const ProfileData& d) {
  for (int b = d.fit_begin; b < d.fit_end; ++b) {
    const int bound = d.bound_at(b);
    if (bound == 0) continue;
    if (bound > 0 || d.ideal_at(d.bin_center_mm(b)) < 0.5) return false;
  }
  return true;
}

// One coarse pattern's step: fitted with free contrast, else read off its
// plateaus; nullopt if neither gives one. `from_plateaus` says which.
std::optional<LevelStep> pattern_level_step(const SampledProfile& p, double px_per_bar, double w_mm,
                                            const MeasureOptions& mo, bool& from_plateaus) {
  from_plateaus = false;
  ProfileFitOptions fo;
  fo.fit_contrast = true;
  fo.fit_shape = mo.fit_psf_shape;  // a fixed Gaussian would put a heavy-tailed PSF's low-frequency loss into the level step
  // The bars free to move within a quarter of a bar, as the element's own
  // grading fit has them (refine_shift_by_fit): the correlation centring
  // leaves them a tenth of a bar or so off, and with the shape free that
  // misplacement reads as heavier tails and a deeper step (the generated
  // chart's G0E1: beta 1.2-1.7 for its Gaussian, each fit's |c| 1-6 %
  // deep, the median's 1-3 %, every m 2-5 % low). Where the fit does not
  // place them, they stay where the centring put them.
  ProfileFit fit = fit_profile(p.data, with_free_shift(fo, w_mm));
  const bool placed = shift_placed(fit, w_mm);
  if (!placed) fit = fit_profile(p.data, fo);
  if (fitted_step_usable(fit) && !at_bound(fit)) return step_of(fit);
  // Plateaus a quarter bar inside each shape need wide bars, and the bars
  // where the fit placed them.
  const std::optional<LevelStep> plateau =
      px_per_bar >= 12 ? plateau_level_step(placed ? shifted_ideal(p.data, fit.shift_mm) : p.data, w_mm)
                       : std::nullopt;
  if (plateau && plateau->distinct_from_zero(5)) {
    from_plateaus = true;
    return plateau;
  }
  // At the bound, with no plateaus to check it: a chrome mask's c can be ~-1.
  if (fitted_step_usable(fit)) return step_of(fit);
  return std::nullopt;
}

}  // namespace

// The level step per orientation (what the reference patch is in layout
// mode): the median of the three coarsest elements that allow it, fitted
// with free contrast, so that one odd pattern (a mismatch, dust on a bar)
// does not scale every other. Where the profile model cannot describe an
// element's edges (a single element filling a microscope frame: bars
// hundreds of pixels wide, so each bin's error is tiny and any fringe is
// a misfit of chi^2 1e7, which pins the fitted step at its bound), the step
// is read off the element's own plateaus instead. One orientation missing:
// the other's stands in (a printed chart has one ink density).
//
// A pattern with more than 2 % of its pixels clipped is left out while
// any other gives a step. Only where none does are those clipped at black
// alone used, their clipped bins read past the clipping or fitted as
// bounds (profiles/censored_level.h): dark bars that reach
// zero, or a resampling's or a sharpening's undershoot at their edges
// pushing them there (dev_11 resized by 0.8 or 1.25 with a Lanczos
// filter). Clipped at saturation, the ground itself is unknown. A single
// pattern and nothing else never is.
bool chart_level_steps(const ChartDetection& D, const std::vector<PatternRef>& refs,
                       const std::vector<ElementJob>& jobs, const std::vector<std::vector<SampledProfile>>& profiles,
                       const MeasureOptions& mo, ReferenceResult& ref, std::string* note) {
  ref.signature = Signature::albedo;
  std::vector<LevelStep> steps[2];  // [vertical bars]
  std::vector<std::string> from_plateaus;
  std::vector<size_t> clipped_dark;  // candidates clipped at black only
  int candidates = 0, clipped = 0;   // coarse patterns in full view, and those of them clipped
  const auto steps_of = [&](size_t i) -> std::vector<LevelStep>& {
    return steps[jobs[i].element.orientation == BarOrientation::vertical_bars];
  };
  const auto add_step = [&](size_t i) {
    const ElementResult& e = jobs[i].element;
    bool plateaus = false;
    const std::optional<LevelStep> step =
        pattern_level_step(profiles[i].front(), e.px_per_bar, refs[i].bar_width_mm(), mo, plateaus);
    if (!step) return false;
    steps_of(i).push_back(*step);
    if (plateaus) from_plateaus.push_back(fmt::format("G{}E{} {}", e.group, e.element, to_string(e.orientation)));
    return true;
  };
  for (size_t i = 0; i < jobs.size(); ++i) {
    const ElementResult& e = jobs[i].element;
    const SampledProfile& p = profiles[i].front();
    if (steps_of(i).size() >= 3 || e.px_per_bar < 3) continue;
    if (D.patterns[refs[i].pattern].predicted || refs[i].lone || !p.in_view) continue;
    ++candidates;
    if (p.pixels_clipped > p.pixels_used / 50) {
      ++clipped;
      if (clipped_at_black_only(p.data)) clipped_dark.push_back(i);
      continue;
    }
    add_step(i);
  }
  // Not for a single pattern: three strokes of a graphic drawn in clipped
  // black look like one (chart_measure.cpp).
  const bool from_clipped = steps[0].empty() && steps[1].empty() && !clipped_dark.empty() && !D.single_pattern;
  int clipped_steps = 0;  // the clipped patterns that gave a step
  if (from_clipped)
    for (const size_t i : clipped_dark)
      if (steps_of(i).size() < 3) clipped_steps += add_step(i);
  for (int vertical = 0; vertical < 2; ++vertical) {
    std::vector<LevelStep>& s = steps[vertical];
    if (s.empty()) continue;
    std::sort(s.begin(), s.end(), [](const LevelStep& a, const LevelStep& b) { return a.contrast < b.contrast; });
    LevelStep median = s[s.size() / 2];
    // The coarse elements measure one step: where they disagree by more
    // than their own fits allow (a profile the model misses by a little,
    // at a signal-to-noise where that is many sigma), their scatter is the
    // step's uncertainty.
    std::vector<double> contrasts;
    for (const LevelStep& step : s) contrasts.push_back(step.contrast);
    median.contrast_sigma = std::max(median.contrast_sigma, sample_sd(contrasts));
    ref.step(vertical ? BarOrientation::vertical_bars : BarOrientation::horizontal_bars) = median;
  }
  const bool have_h = !steps[0].empty(), have_v = !steps[1].empty();
  if (!have_h && !have_v) {
    if (note)
      *note = clipped > 0
                  ? fmt::format("the chart's level step cannot be measured: {} of the {} coarse pattern(s) in full "
                                "view with 3 or more pixels per bar have more than 2 % of their pixels clipped (at "
                                "black or at the saturation level){}; expose so that neither the bars nor the ground "
                                "clip (a JPEG's ringing can push dark bars to 0: export without it, or lift black)",
                                clipped, candidates, clipped < candidates ? ", and the others show no bars to read" : "")
                  : "the chart's level step cannot be measured: no element in full view has 3 or more pixels per bar "
                    "with visible bars; frame a coarser group or bring the chart into focus";
    return false;
  }
  if (!have_h) ref.horizontal_bars = {ref.vertical_bars.contrast, ref.vertical_bars.contrast_sigma, 0};
  if (!have_v) ref.vertical_bars = {ref.horizontal_bars.contrast, ref.horizontal_bars.contrast_sigma, 0};
  ref.usable = true;
  if (note && clipped_steps > 0)
    *note = fmt::format("the level step was fitted on coarse patterns with more than 2 % of their pixels clipped at "
                        "black ({} of the {} in full view; none unclipped gave one), their clipped bins read past "
                        "the clipping or taken as bounds: lift black or export without sharpening for a step measured "
                        "throughout",
                        clipped_steps, candidates);
  if (note && !from_plateaus.empty()) {
    std::string which;
    for (const std::string& w : from_plateaus) which += (which.empty() ? "" : ", ") + w;
    *note += fmt::format(
        "{}the level step was read off the plateaus of {} (the profile model does not fit those bars' edges within "
        "their noise); check that their middles are flat",
        note->empty() ? "" : "; ", which);
  }
  return true;
}

}  // namespace tactres::chart
