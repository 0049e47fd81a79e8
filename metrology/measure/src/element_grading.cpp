#include "tactres/measure/element_grading.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <numbers>
#include <optional>
#include <tuple>

#include <fmt/format.h>

#include "tactres/profiles/gap_dips.h"
#include "tactres/targets/usaf_series.h"
#include "tactres/util/stopwatch.h"

namespace tactres {

namespace {
// Relative standard uncertainty of ln m from the shading model itself
// (docs/CONVENTIONS.md, "Criterion and limits").
constexpr double kShadingModelLogSigma = 0.012;
// Aliasing needs a misfit at least this large against the RMS of the fitted
// signature: ~1.1 RMS is half the peak-to-peak of the bars' fundamental.
constexpr double kAliasingMisfitShare = 1.1;

// What the Rose CNR needs from an ok element's own fit
// (profiles/detectability.h): the signal from the fitted m, the fixed level
// step (its RMS over the triplet when a gain field turns it) and the local
// ground level B0; the level whose noise counts; the
// pixels of one bar. The noise itself comes from the whole capture
// (element_pipeline.cpp, pool_noise).
void set_signal(ElementResult& r, const SampledProfile& sp, const ProfileFit& fit, const ProfileFitOptions& fo) {
  r.signal = bar_signal_ptp(r.m, rms_step_over_triplet(fo.contrast, fo.contrast_slope_per_mm, r.lp_per_mm), fit.b0,
                            fo.signature, r.lp_per_mm);
  r.mean_level = element_mean_level(fo.contrast, fit.b0, fo.signature);
  const double anisotropy = sp.px_per_mm_across > 0 ? sp.px_per_mm_along / sp.px_per_mm_across : 1.0;
  r.bar_pixels = pixels_per_bar(r.px_per_bar, anisotropy);
}
// The image's pixel pitch across the bars (mm), 0 if unknown.
double pixel_mm(const SampledProfile& sp) { return sp.px_per_mm_across > 0 ? 1.0 / sp.px_per_mm_across : 0.0; }
// "N % of its pixels are clipped (black or saturated)", then `rest`.
std::string clipped_note(const SampledProfile& sp, const std::string& rest = "") {
  return fmt::format("{:.0f} % of its pixels are clipped (black or saturated){}",
                     100.0 * sp.pixels_clipped / std::max(1, sp.pixels_used), rest);
}

// Marks an ok element whose triplet shows one gap flat (profiles/gap_dips.h)
// on the profile it was graded on. Printed bars only: a relief's shading
// signature is a slope, with no dips to read.
// The dips of r's triplet in the profile `d` sampled as `sp`
// (profiles/gap_dips.h), `contrast` the model's level step.
GapDips triplet_dips(const ElementResult& r, const SampledProfile& sp, const ProfileData& d, double contrast) {
  return gap_dips(d, 0.5 / r.lp_per_mm, contrast, pixel_mm(sp));
}

void note_flat_gap(ElementResult& r, const GapDips& g) {
  const std::optional<int> flat = g.flat_gap();
  if (!flat) return;
  r.gap_flat = true;
  const int k = *flat;
  const std::string why =
      fmt::format("its {} gap shows no dip ({:.1f} sigma; the other dips {:.1f} sigma): two bars are seen, not "
                  "three, so it is not resolved",
                  k == 0 ? "first" : "second", g.dip[k] / g.sigma[k], g.dip[1 - k] / g.sigma[1 - k]);
  r.note = r.note.empty() ? why : why + "; " + r.note;
}

// m read model-free from a triplet whose gaps both dip over 5 sigma
// (profiles/gap_dips.h): near the limit only the bars' fundamental is left,
// whose crest-to-trough is 4/pi m of the level step |c| B, B the unclipped
// ground beside the triplet or the fit's B0 if higher (the larger step, the
// lower m), so m is pi/4 of the shallower dip over that step. The reading
// is approximate: the windows' half-bar width reads it ~10 % low, a
// defocused triplet's reversed third harmonic and the best of the shifted
// windows read it high; kDipModelSigma covers that, as a type-B term.
// None where the ground beside the triplet is all clipped (the step
// unknown) or m comes out above 1 (a halo's overshoot, not the bars).
// Printed bars in chart photographs only.
constexpr double kDipModelSigma = 0.15;  // relative
struct DipReading {
  double m = 0, m_sigma = 0;
  GapDips dips;
};
// `g`: the triplet's dips (triplet_dips); `clearly`: both over 5 sigma
// (GapDips::three_bars), else both above zero.
std::optional<DipReading> read_dips(const ElementResult& r, const GapDips& g, const ProfileFit& fit,
                                    const ProfileFitOptions& fo, double contrast_sigma, bool clearly = true) {
  if (!fit.usable || fo.signature != Signature::albedo) return std::nullopt;
  const bool dip = clearly ? g.three_bars() : g.valid && g.dip[0] > 0 && g.dip[1] > 0;
  if (!dip || !(g.ground > 0)) return std::nullopt;
  const int k = g.dip[0] < g.dip[1] ? 0 : 1;
  const double c = std::abs(rms_step_over_triplet(fo.contrast, fo.contrast_slope_per_mm, r.lp_per_mm));
  const double step = c * std::max(fit.b0, g.ground);
  if (!std::isfinite(step) || step <= 0) return std::nullopt;
  const double m = std::numbers::pi / 4 * g.dip[k] / step;
  const double m_sigma =
      std::hypot(std::numbers::pi / 4 * g.sigma[k] / step, m * contrast_sigma / c, kDipModelSigma * m);
  if (!std::isfinite(m) || !std::isfinite(m_sigma) || m > 1) return std::nullopt;
  return DipReading{m, std::max(m_sigma, 1e-6), g};
}

// A clipped element whose fit cannot measure m (the clipping, or a
// resampled photograph's halos, bend its profile beyond the model), yet
// whose data show all three bars: m is read from the dips (read_dips). It
// is graded like a fit's m (resolved or not by the criterion, so an
// unresolved one ends the chain). Where no dip reading can be taken, the
// element stays unmeasured (clipped), which the limit bridges. Returns
// whether it graded `r`.
bool grade_from_dips(ElementResult& r, const SampledProfile& sp, const ProfileData& d, const ProfileFit& fit,
                     const ProfileFitOptions& fo, double contrast_sigma, const std::string& why) {
  const std::optional<DipReading> dr = read_dips(r, triplet_dips(r, sp, d, fo.contrast), fit, fo, contrast_sigma);
  if (!dr) return false;
  r.m = dr->m;
  r.m_sigma = dr->m_sigma;
  r.dips_m = dr->m;
  r.dips_m_sigma = dr->m_sigma;
  r.beta = 0;
  r.chi2_reduced = fit.chi2_reduced;
  r.m_from_dips = true;
  r.status = ElementStatus::ok;
  ProfileFit ground_fit = fit;  // the CNR's signal on the step's ground
  ground_fit.b0 = std::max(fit.b0, dr->dips.ground);
  set_signal(r, sp, ground_fit, fo);
  r.note = fmt::format("{}, but both gaps dip ({:.0f} and {:.0f} sigma): m is read model-free, pi/4 of the shallower "
                       "dip over the level step (+-{:.0f} % for that approximation)",
                       why, dr->dips.dip[0] / dr->dips.sigma[0], dr->dips.dip[1] / dr->dips.sigma[1],
                       100 * kDipModelSigma);
  return true;
}

// An element of a chart photograph under the sampling floor counts only
// where it is plainly seen: ok (by its fit, or by its dips when clipped),
// with both gaps dipping over 5 sigma (profiles/gap_dips.h), as a person
// reading the profile would call three bars. Anything else there is
// below_sampling_limit, as without the fit, its grading's reason kept in
// the note: near Nyquist a failed or faint fit says more about the
// sampling phase than about the optics. Returns whether r was kept.
bool keep_under_floor_if_seen(ElementResult& r, const SampledProfile& sp, const ProfileData& d,
                              const ProfileFitOptions& fo, double min_px_per_bar) {
  const bool checked = r.status == ElementStatus::ok && fo.signature == Signature::albedo;
  const GapDips g = checked ? triplet_dips(r, sp, d, fo.contrast) : GapDips{};
  const std::string floor = fmt::format("{:.2f} px per bar, under the {:.2f} floor", r.px_per_bar, min_px_per_bar);
  if (g.three_bars()) {
    r.note = fmt::format("{}: kept because its data show all three bars{}", floor, r.note.empty() ? "" : "; " + r.note);
    return true;
  }
  const std::string why = !checked ? fmt::format(", and it is not measured ({}{}{})", to_string(r.status),
                                                 r.note.empty() ? "" : ": ", r.note)
                                   : ", and its data do not show all three bars clearly";
  const std::array<Vec2, 4> outline = r.outline_px;
  r = ElementResult::of(r.group, r.element, r.orientation, r.lp_per_mm, r.px_per_bar);
  r.outline_px = outline;
  r.outline_valid = true;
  r.status = ElementStatus::below_sampling_limit;
  r.note = floor + why;
  return false;
}

// An ok element whose LSF shape stops on its bound, where the data press
// beyond it (ProfileFit::beta_bound_sigmas): its m is the bounded family's,
// and says so when lifting the bound would move m by more than m_sigma.
// (Below beta 1 the stable laws are a core with a halo; above 4 a flat
// disc. The bounds stay: at a floor of 0.5, m followed the floor on real
// frames, docs/CHART.md.)
void note_shape_bound(ElementResult& r, const ProfileFit& fit) {
  constexpr double kPressSigmas = 2;
  if (fit.beta_bound_sigmas < kPressSigmas) return;
  const double dm = fit.transfer_change_unbounded(r.lp_per_mm);
  if (!(std::abs(dm) > r.m_sigma)) return;
  const bool lower = fit.unbounded_step_beta < 0;
  r.note += fmt::format("{}the LSF shape is held at its bound beta = {:.3g} (the data favour beta {} it by {:.1f} "
                        "sigma): m and the status are the bounded model's; with the bound lifted m would be about "
                        "{:.3f} ({:+.2g}; m_sigma {:.2g})",
                        r.note.empty() ? "" : "; ", fit.beta, lower ? "below" : "above", fit.beta_bound_sigmas,
                        std::clamp(r.m + dm, 0.0, 1.0), dm, r.m_sigma);
}

// An element whose fit misses its data as much as the bars' own signal,
// at under 3 px per bar (grade_fit's aliasing test): the bars are not
// where the geometry puts them at this sampling, the image shows another
// period or bar count. Both tests must agree: the misfit exceeds the
// noise, and it is comparable to the bars' own fitted signal (as if m were
// at least 0.05), for both signatures alike (a relief's slope signal is
// not the level step times m). A noise-free capture's small model error
// passes the first test alone.
// - With clipped bins the misfit cannot tell aliasing from a profile the
//   clipping distorted beyond the model (a resampled photograph's
//   overshoot at the clip level): such an element stays `clipped`, as it
//   was before clipped bins were fitted as bounds.
// - On a chart photograph, one whose three bars show anyway (both gaps dip
//   where the layout puts them) is read from its dips, clipped or not: the
//   bars are where the geometry puts them, so this is no alias but a
//   profile the model misses (dev_14 resized by 1.25: G7E1 V at 1.9 px per
//   bar, its gaps at 0.2 of the ground and its bars at 0.02, fitted at
//   reduced chi^2 291).
void grade_misfit(ElementResult& r, const SampledProfile& sp, const ProfileData& data, const ProfileFit& fit,
                  const ProfileFitOptions& fo, double contrast_sigma, bool read_gap_dips, bool clipped) {
  if (read_gap_dips &&
      grade_from_dips(r, sp, data, fit, fo, contrast_sigma,
                      fmt::format("the model misses the data (reduced chi^2 {:.3g})", fit.chi2_reduced)))
    return;
  if (!clipped) {
    r.status = ElementStatus::aliased;
    r.note = fmt::format("the data do not show the layout's bars at {:.2f} px per bar (reduced chi^2 {:.3g})",
                         r.px_per_bar, fit.chi2_reduced);
    return;
  }
  r.status = ElementStatus::clipped;
  r.note = clipped_note(sp, fmt::format("; the fit with them as bounds misses the data (reduced chi^2 {:.3g}, "
                                        "misfit as large as the bars' signal)",
                                        fit.chi2_reduced));
}

// Fits `data` (the strip's profile, prepared) and grades r by the fit:
// grade_element's contract from the fit on.
void grade_fit(ElementResult& r, const SampledProfile& sp, const ProfileData& data, const ProfileFitOptions& fo,
               double contrast_sigma, const MeasureOptions& options, std::pair<double, double>& warm_lsf,
               bool model_mismatch, bool read_gap_dips, bool clipped) {
  const ProfileFit fit = fit_profile(data, fo);
  if (fit.usable && !clipped) warm_lsf = {fit.nu0_per_mm, fit.beta};
  if (!fit.usable || (clipped && fit.transfer_sigma(r.lp_per_mm) > options.max_m_sigma)) {
    // What the clipping left does not pin the bars down: clipped, not a
    // failed fit or a faint element.
    if (clipped && read_gap_dips &&
        grade_from_dips(r, sp, data, fit, fo, contrast_sigma, "the rest does not pin the model's m down")) {
      r.note = clipped_note(sp, ": fitted with those bins as bounds; " + r.note);
      return;
    }
    r.status = clipped ? ElementStatus::clipped : ElementStatus::fit_failed;
    if (clipped) r.note = clipped_note(sp, "; the rest does not pin m down");
    // Every failed element says why (a placed pattern on empty ground, dust).
    else r.note = "the profile model could not be fitted here: " +
                  (fit.problem.empty() ? std::string("no usable fit") : fit.problem);
    return;
  }
  const double m = fit.transfer(r.lp_per_mm);
  double fit_sigma = fit.transfer_sigma(r.lp_per_mm);
  // The shading (relief) model is biased: on independent relief captures
  // (tests/reference, any light direction, noise-free) it reads
  // ln m about 1.2 % of ln m too low, so the interpolated limit ~0.6 % low,
  // several times its fit-only sigma. That known model uncertainty (a GUM
  // type-B term) enters m_sigma, so the stated intervals cover the truth.
  if (fo.signature == Signature::shading && m > 0)
    fit_sigma = std::hypot(fit_sigma, kShadingModelLogSigma * m * std::abs(std::log(m)));
  // The level step's error scales the whole signature: m moves with it to
  // first order (dm/dc ~ -m/c), c the step the bars shade with (its RMS over
  // the triplet when a gain field turns it).
  const double step_sigma =
      m * contrast_sigma / std::abs(rms_step_over_triplet(fo.contrast, fo.contrast_slope_per_mm, r.lp_per_mm));
  const double m_sigma = std::hypot(fit_sigma, step_sigma);
  r.beta = fit.beta;
  r.chi2_reduced = fit.chi2_reduced;
  if (!std::isfinite(m) || !std::isfinite(m_sigma)) {
    r.status = ElementStatus::fit_failed;
    r.note = "the fit gives no finite m or m_sigma here";
  } else if (!model_mismatch && fit.chi2_reduced > options.aliasing_chi2 && r.px_per_bar < 3.0 &&
             fit.residual_rms > kAliasingMisfitShare * fit.signal_rms * std::max(1.0, 0.05 / std::max(m, 1e-9))) {
    grade_misfit(r, sp, data, fit, fo, contrast_sigma, read_gap_dips, clipped);
  } else if (m < 1e-4 && m_sigma < 1e-4) {
    // The fit sits on its bound (no modulation left): there the covariance
    // collapses, and "m = 0 +- 1e-6" would claim a certainty the data do
    // not give. Not resolved, and said so.
    r.status = ElementStatus::low_signal;
    r.note = "the fit drives m to 0 (no modulation left at this frequency); its error cannot be estimated there";
  } else if (fit_sigma > options.max_m_sigma) {
    // Only the fit's own error grades an element: a step known poorly at
    // the element's place (a gain field near a line where the light runs
    // along the bars; the patch's own step stands 5 sigma out, so it alone
    // never exceeds the limit) leaves m as the fit found it, with the
    // step's error in m_sigma, where the criterion (m - 2 sigma > 0) weighs it.
    // On a chart photograph an element whose fit cannot pin m down while
    // both its gaps dip clearly is read from its dips, as a misfit is
    // (grade_misfit): its bars show. (Its m is then measured, so an
    // unresolved one ends the chain where a low_signal one was bridged.)
    const std::string why = fmt::format("m_sigma {:.3g} > {:.3g}: the fit cannot pin m down", fit_sigma,
                                        options.max_m_sigma);
    if (!read_gap_dips || !grade_from_dips(r, sp, data, fit, fo, contrast_sigma, why)) {
      r.status = ElementStatus::low_signal;
      r.m_undetermined = true;
      r.note = why;
    }
  } else {
    r.status = ElementStatus::ok;
    r.m = m;
    r.m_sigma = std::max(m_sigma, 1e-6);
    set_signal(r, sp, fit, fo);
    // The covariance is already scaled by the reduced chi^2 (profile_fit.h),
    // so m_sigma carries the misfit; a person still needs to know.
    r.m_scale_undetermined = step_sigma > options.max_m_sigma;
    if (r.m_scale_undetermined)
      r.note = fmt::format("m_sigma {:.3g} is mostly the level step's error here ({:.0f} % of the step, from the gain "
                           "field): the fit itself pins m to {:.3g}",
                           m_sigma, 100 * contrast_sigma / std::abs(fo.contrast), fit_sigma);
    else if (fit.chi2_reduced > options.poor_fit_chi2)
      r.note = fmt::format("poor fit (reduced chi^2 {:.3g}): the profile model does not describe these bars well; "
                           "m_sigma is widened by sqrt(chi^2){}",
                           fit.chi2_reduced, model_mismatch ? "; the reference patch shows the same mismatch" : "");
    note_shape_bound(r, fit);
  }
  if (read_gap_dips && r.status == ElementStatus::ok && fo.signature == Signature::albedo) {
    const GapDips g = triplet_dips(r, sp, data, fo.contrast);
    note_flat_gap(r, g);
    // The dips read model-free beside the fit's m, which they may show
    // above zero where a poor fit's widened m_sigma cannot (criterion.h).
    if (!r.m_from_dips)
      if (const std::optional<DipReading> dr = read_dips(r, g, fit, fo, contrast_sigma, false))
        r.dips_m = dr->m, r.dips_m_sigma = dr->m_sigma;
  }
  if (clipped && r.status == ElementStatus::ok)
    r.note = clipped_note(sp, ": fitted with those bins as bounds" + (r.note.empty() ? "" : "; " + r.note));
}

}  // namespace

double grade_element(ElementResult& r, const SampledProfile& sp, ProfileFitOptions fo, double contrast_sigma,
                     const MeasureOptions& options, std::pair<double, double>& warm_lsf,
                     const ProfilePrepare& prepare, bool model_mismatch, bool read_gap_dips) {
  r.outline_px = sp.outline_px;
  r.outline_valid = sp.in_view;
  if (!sp.in_view) {
    r.status = ElementStatus::out_of_view;
    return 0;
  }
  // Under the floor (a margin against the sampling phase, not a hard
  // limit) a chart photograph's element is still fitted, and kept only if
  // its data show all three bars (keep_under_floor_if_seen).
  const bool under_floor = r.px_per_bar < options.min_px_per_bar;
  if ((under_floor && !read_gap_dips) || r.px_per_bar <= 1.0) {
    // At or beyond Nyquist (<= 1 px per bar) the bars are never resolved,
    // whatever --min-px-per-bar allows: binning by sub-pixel phase can
    // still recover the pre-sampling MTF there, but the image shows an
    // alias, not the bars (docs/CONVENTIONS.md, "Element statuses").
    r.status = ElementStatus::below_sampling_limit;
    r.note = r.px_per_bar <= 1.0 ? fmt::format("{:.2f} px per bar: at or beyond Nyquist, the image shows an alias",
                                               r.px_per_bar)
                                 : fmt::format("{:.2f} px per bar, under the {:.2f} floor (--min-px-per-bar)",
                                               r.px_per_bar, options.min_px_per_bar);
    return 0;
  }
  // Clipped bins enter the fit as bounds (ProfileData::bound); with most
  // of the strip clipped, too little is measured to fit.
  const bool clipped = sp.pixels_clipped > sp.pixels_used / 50;
  if (sp.pixels_clipped > sp.pixels_used / 2) {
    r.status = ElementStatus::clipped;
    r.note = clipped_note(sp);
    if (under_floor) keep_under_floor_if_seen(r, sp, sp.data, fo, options.min_px_per_bar);
    return 0;
  }
  const Stopwatch fit_time;
  std::tie(fo.start_nu0_per_mm, fo.start_beta) = warm_lsf;
  const ProfileData prepared = prepare ? prepare(sp.data, fo) : ProfileData{};
  const ProfileData& data = prepare ? prepared : sp.data;  // no copy without a prepare
  const std::pair<double, double> warm_before = warm_lsf;
  grade_fit(r, sp, data, fo, contrast_sigma, options, warm_lsf, model_mismatch, read_gap_dips, clipped);
  // A fit thrown away under the floor does not start the next one.
  if (under_floor && !keep_under_floor_if_seen(r, sp, data, fo, options.min_px_per_bar)) warm_lsf = warm_before;
  return fit_time.seconds();
}

bool is_unmeasured(const ElementResult& r, bool chart_photograph) {
  const ElementStatus s = r.status;
  return s == ElementStatus::fit_failed || s == ElementStatus::clipped || s == ElementStatus::damaged ||
         (s == ElementStatus::low_signal && r.m_scale_undetermined) ||
         (chart_photograph && (s == ElementStatus::out_of_view || r.m_undetermined));
}

namespace {

// The bars shown above zero by the model-free reading of their gaps: that
// reading itself resolved by the criterion (ElementResult::dips_m).
// Never for a triplet with a flat gap (two bars seen, not three).
bool shown_by_dips(const ElementResult& r, const Criterion& criterion) {
  return r.dips_m_sigma > 0 && !r.gap_flat &&
         is_resolved({r.group, r.element, r.lp_per_mm, r.dips_m, r.dips_m_sigma, true}, criterion);
}

// The element as the criterion sees it (its unmeasured flag apart).
MPoint criterion_point(const ElementResult& r, const Criterion& criterion) {
  MPoint p{r.group, r.element, r.lp_per_mm, r.m, r.m_sigma, r.status == ElementStatus::ok && !r.gap_flat};
  p.shown_by_dips = shown_by_dips(r, criterion);
  return p;
}

// Fitted and resolved by the criterion: what ElementResult::resolved says.
bool ok_and_resolved(const ElementResult& r, const Criterion& criterion) {
  return is_resolved(criterion_point(r, criterion), criterion);
}

}  // namespace

void grade_damaged(Measurement& M, const Criterion& criterion) {
  for (const BarOrientation o : {BarOrientation::horizontal_bars, BarOrientation::vertical_bars}) {
    std::vector<ElementResult*> row;  // this orientation's fitted elements, coarse to fine
    for (ElementResult& r : M.elements)
      if (r.orientation == o && !is_unmeasured(r, true) &&
          (r.status == ElementStatus::ok || r.status == ElementStatus::aliased || r.status == ElementStatus::low_signal))
        row.push_back(&r);
    std::stable_sort(row.begin(), row.end(),
                     [](const ElementResult* a, const ElementResult* b) { return a->lp_per_mm < b->lp_per_mm; });
    const double step = std::exp2(1.0 / 6);  // one element finer
    // Fine to coarse, so that one element judged damaged is passed over as
    // a coarser one looks for the next two finer: in a blurred copy of
    // dev_01 the bundle's rim takes G5E3-E5 H (m 0, fit_failed, m 0) and
    // the finer G6E1 and G6E2 read m 0.54 and 0.56; judged coarse to fine,
    // G5E3 saw G5E5 still unresolved, ended the chain, and H read "nothing
    // resolved". One only: a longer run without bars before two finer
    // readings is no local defect the chain may pass in silence.
    for (size_t i = row.size(); i-- > 0;) {
      ElementResult& e = *row[i];
      if (ok_and_resolved(e, criterion)) continue;
      std::vector<const ElementResult*> finer;  // the next two finer, past at most one judged damaged
      int passed_over = 0;
      for (size_t k = i + 1; k < row.size() && finer.size() < 2; ++k)
        if (row[k]->status != ElementStatus::damaged) finer.push_back(row[k]);
        else if (finer.empty()) ++passed_over;
      if (finer.size() < 2 || passed_over > 1) continue;
      // ok and unresolved: its m and sigma; aliased (no bars at all) and
      // low_signal (here: m driven to 0, its error not estimable): m = 0.
      const bool fitted = e.status == ElementStatus::ok;
      const double m = fitted ? e.m : 0.0, sigma = fitted ? e.m_sigma : 0.0;
      // The next two elements of the series, both resolved, each 3 combined
      // sigma above this one and at m >= 0.3: past a defocus disc's first
      // zero the bars come back contrast-reversed, but at m of 0.13-0.22
      // at most, which a pattern locked half a period off could read.
      // Each on the series past the one before, with at most one element
      // of the series between them not found at all (dev_01's 16-bit copy:
      // G5E6, cut away by the fibre bundle's edge, lies between G5E5 and
      // G6E1); elements found between them but not measured do not count
      // (their indices are known: in a JPEG copy of dev_01's 8-bit frame
      // G5E5 H is fit_failed, and G5E4 H, its bars cut by that edge, fits m 0).
      bool finer_show_bars = true;
      for (size_t k = 0; k < 2; ++k) {
        const ElementResult& f = *finer[k];
        const double coarser_lp = (k == 0 ? e : *finer[0]).lp_per_mm;
        const double steps = std::log(f.lp_per_mm / coarser_lp) / std::log(step);
        const long whole_steps = std::lround(steps);
        const long found_between = std::count_if(M.elements.begin(), M.elements.end(), [&](const ElementResult& x) {
          return x.orientation == o && x.lp_per_mm > coarser_lp * 1.01 && x.lp_per_mm < f.lp_per_mm / 1.01;
        });
        const bool near_in_series =
            std::abs(steps - whole_steps) < 0.15 && whole_steps >= 1 && whole_steps - 1 - found_between <= 1;
        finer_show_bars = finer_show_bars && near_in_series && ok_and_resolved(f, criterion) && f.m >= 0.3 &&
                          f.m - m > 3 * std::hypot(f.m_sigma, sigma);
      }
      if (!finer_show_bars) continue;
      const ElementResult &f1 = *finer[0], &f2 = *finer[1];
      e.note = fmt::format(
          "{}; the finer G{}E{} and G{}E{} read m = {:.2f} and {:.2f}: a local defect over this element (dust, a "
          "scratch, the field's blurred edge), not the optics; left out of the limit",
          e.gap_flat ? fmt::format("its bars read m = {:.2f} +- {:.2f}, but one gap shows no dip", m, sigma)
          : fitted   ? fmt::format("its bars read m = {:.2f} +- {:.2f}", m, sigma)
                     : std::string(e.status == ElementStatus::aliased ? "its profile does not show the element's bars"
                                                                      : "the fit drives its m to 0"),
          f1.group, f1.element, f2.group, f2.element, f1.m, f2.m);
      e.status = ElementStatus::damaged;
    }
  }
}

namespace {

// On a chart photograph, the elements of the series between the coarsest
// and the finest of one orientation that were not found at all (cut off,
// under dust, beyond the detector's reach): unmeasured, so that the chain
// lists them where it passes them (Limit::bridged) instead of passing them
// in silence (a copy of dev_11 cut in half lost all of group 1, and its H
// limit went from G0E6 to G2E5 with nothing said).
void add_elements_not_found(const Measurement& M, BarOrientation o, std::vector<MPoint>& m,
                            std::vector<CnrPoint>& cnr) {
  // A relative chart's frequencies are multiples of G0E1's, the series'
  // own values too.
  std::set<int> found;  // by usaf_index
  for (const ElementResult& r : M.elements)
    if (r.orientation == o) found.insert(usaf_index(r.group, r.element));
  if (found.empty()) return;
  for (int n = *found.begin() + 1; n < *found.rbegin(); ++n) {
    if (found.count(n)) continue;
    const UsafElement e = usaf_element_at(n);
    const double lp_per_mm = usaf_lp_per_mm(e.group, e.element);
    m.push_back({e.group, e.element, lp_per_mm, 0, 0, false, true});
    cnr.push_back({e.group, e.element, lp_per_mm, 0, 0, false, true});
  }
}

}  // namespace

void decide_limits(Measurement& M, const Criterion& criterion, const DetectabilityCriterion& detectability,
                   bool chart_photograph) {
  for (const BarOrientation o : {BarOrientation::horizontal_bars, BarOrientation::vertical_bars}) {
    std::vector<MPoint> m;
    std::vector<CnrPoint> cnr;
    if (chart_photograph) add_elements_not_found(M, o, m, cnr);
    for (const ElementResult& r : M.elements) {
      if (r.orientation != o) continue;
      const bool ok = r.status == ElementStatus::ok, unmeasured = is_unmeasured(r, chart_photograph);
      // An element whose step alone leaves m unresolved says nothing about
      // the optics (the light hardly shades it there): bridged for the
      // optical limit. Its CNR, the bars' own signal, still counts.
      MPoint point = criterion_point(r, criterion);  // usable: ok, no flat gap
      MPoint fitted = point;                         // the flat gap aside
      fitted.usable = ok;
      const bool unscaled = ok && r.m_scale_undetermined && !is_resolved(fitted, criterion);
      point.usable = point.usable && !unscaled;
      point.unmeasured = unmeasured || unscaled;
      m.push_back(point);
      cnr.push_back({r.group, r.element, r.lp_per_mm, r.cnr, r.cnr_sigma, ok, unmeasured, r.noise_shot_fraction,
                     point.shown_by_dips});
    }
    const LimitBreakdown parts = decide_breakdown(std::move(m), std::move(cnr), criterion, detectability);
    const bool h = o == BarOrientation::horizontal_bars;
    (h ? M.horizontal_parts : M.vertical_parts) = parts;
    (h ? M.horizontal : M.vertical) = parts.reported();
  }
  for (ElementResult& r : M.elements) {
    r.resolved = ok_and_resolved(r, criterion);
    const bool by_dips = shown_by_dips(r, criterion);
    // Above the threshold yet not resolved: say why, or the status reads
    // as a contradiction. Resolved only by its dips: say so.
    const bool above = r.status == ElementStatus::ok && std::isfinite(r.m) && r.m >= criterion.threshold && !r.gap_flat;
    const bool fit_significant = r.m - criterion.significance_z * r.m_sigma > 0;
    if (above && !r.resolved)
      r.note += fmt::format("{}m {:.3f} is above the threshold {:g} but not {:g} sigma above 0 (m_sigma {:.3f}): "
                            "not resolved",
                            r.note.empty() ? "" : "; ", r.m, criterion.threshold, criterion.significance_z, r.m_sigma);
    else if (above && by_dips && !fit_significant)
      r.note += fmt::format("{}m {:.3f} is not {:g} sigma above 0 by the fit (m_sigma {:.3f}), but read model-free from "
                            "its gaps' dips, m {:.3f} +- {:.3f}, it is: resolved",
                            r.note.empty() ? "" : "; ", r.m, criterion.significance_z, r.m_sigma, r.dips_m,
                            r.dips_m_sigma);
    CnrPoint c{r.group, r.element, r.lp_per_mm, r.cnr, r.cnr_sigma, r.status == ElementStatus::ok};
    c.shown_by_dips = by_dips;
    r.detectable = is_detectable(c, detectability);
  }
}

std::string unresolved_chart_problem(const std::vector<ElementResult>& elements) {
  int in_view = 0, fitted = 0, clipped = 0;
  for (const ElementResult& e : elements) {
    in_view += e.status != ElementStatus::out_of_view;
    fitted += e.status == ElementStatus::ok;
    clipped += e.status == ElementStatus::clipped;
  }
  if (fitted == 0 && clipped > 0)
    return fmt::format("no element on the chart could be measured: {} of the {} elements in view have too many "
                       "pixels clipped (black or saturated) to pin m down, and none was measured; expose so that "
                       "neither the bars nor the ground clip, or lift black",
                       clipped, in_view);
  return "nothing on the chart is resolved: even the coarsest element found is below the criterion; bring the "
         "chart into focus or frame coarser groups";
}

}  // namespace tactres
