#pragma once
// Grading one element's profile, and deciding the limits from the graded
// elements: the single place where a sampled strip becomes a status and
// m(f) (docs/CONVENTIONS.md, "Element statuses"). The element pipeline
// (element_pipeline.h) calls it for layout and chart mode alike, so that
// both grade by the same rules.
//
// grade_element() contract:
// - In: `r` with group, element, orientation, lp_per_mm and px_per_bar set;
//   the strip `sp` sampled for it; `fo` with the signature, the fixed level
//   step (`contrast`) and fit_shape set; `contrast_sigma`, the standard
//   error of that level step; `warm_lsf`, the (nu0, beta) of the previous
//   good fit in the same direction (0, 0 = none), updated on success.
// - Out: r.outline_px / r.outline_valid from the strip; r.status by the
//   first test that applies, in this order:
//     out_of_view           the strip is not fully in the image;
//     below_sampling_limit  px_per_bar <= 1, or < options.min_px_per_bar
//                           (with read_gap_dips: unless the fit is ok and
//                           both gaps dip over 5 sigma, a note says so);
//     clipped               more than half of the strip's pixels clipped;
//                           or more than 2 % and the fit with the clipped
//                           bins as bounds (ProfileData::bound) fails, leaves
//                           m_sigma > options.max_m_sigma, or misses the
//                           data as the aliasing test below says (with
//                           bounds it cannot tell aliasing from clipping);
//     fit_failed            the solver failed, or m / m_sigma not finite;
//     aliased               px_per_bar < 3 and reduced chi^2 > aliasing_chi2
//                           and a residual > half the bars' own modulation,
//                           unless `model_mismatch` (the reference patch
//                           already shows a global mismatch, such as a wrong
//                           pixel encoding: that, not aliasing, explains it);
//     low_signal            the fit sits at m = 0 (m and m_sigma < 1e-4: its
//                           covariance collapses there), or m_sigma >
//                           options.max_m_sigma;
//     ok                    m and m_sigma (>= 1e-6) are set; r.note says so
//                           when the reduced chi^2 exceeds poor_fit_chi2,
//                           and when more than 2 % of the pixels are clipped;
//                           with read_gap_dips also an element read from its
//                           dips (below) that would be clipped, aliased or
//                           low_signal (m_sigma too large) by its fit.
//   r.beta and r.chi2_reduced are set whenever the fit was usable; m and
//   m_sigma stay 0 unless the status is ok. r.resolved is not touched
//   (decide_limits sets it).
// - m = T(f) of the fitted line-spread function; m_sigma combines the fit's
//   standard error with the level step's (dm/dc ~ -m/c).
// - `prepare`, when given, transforms the profile before the final fit with
//   the same fit options (chart mode centres the ideal pattern on the data
//   there); its time counts as fitting time.
// - `read_gap_dips` (chart photographs): an ok element of printed bars
//   (albedo) whose profile shows one gap flat while the other dips
//   (profiles/gap_dips.h) gets r.gap_flat and a note; decide_limits never
//   resolves it. With it, an element that would be `clipped` because the
//   fit with its clipped bins as bounds cannot measure m, `aliased`
//   because the fit misses the data, or `low_signal` because the fit's
//   m_sigma is too large, is ok when both its gaps dip over 5 sigma and
//   the ground beside it is not all clipped:
//   m is then pi/4 of the shallower dip over the level step, model-free,
//   with a 15 % type-B term in m_sigma, and r.m_from_dips is set. Every
//   other ok element whose gaps both dip gets the same model-free reading
//   in r.dips_m / r.dips_m_sigma (0 = none; equal to m when m_from_dips),
//   which decide_limits lets show the bars above zero (criterion.h,
//   MPoint::shown_by_dips). Layout mode keeps the criterion the truth file
//   uses: dips_m_sigma stays 0 there.
// - Returns the seconds spent fitting (0 when no fit ran). Never throws for
//   a bad profile: every failure is a status.

#include <functional>
#include <string>
#include <utility>

#include "tactres/measure/measurement.h"
#include "tactres/profiles/profile_sampler.h"

namespace tactres {

using ProfilePrepare = std::function<ProfileData(const ProfileData&, const ProfileFitOptions&)>;

double grade_element(ElementResult& r, const SampledProfile& sp, ProfileFitOptions fo, double contrast_sigma,
                     const MeasureOptions& options, std::pair<double, double>& warm_lsf,
                     const ProfilePrepare& prepare = {}, bool model_mismatch = false, bool read_gap_dips = false);

// The limits per orientation from M.elements: the optical limit under
// `criterion`, the detectability limit under `detectability`, both into
// M.horizontal_parts / M.vertical_parts and the coarser (the reported one)
// into M.horizontal / M.vertical; and each element's `resolved` and
// `detectable`. An ok element
// counts by the criterion; an unmeasured one (is_unmeasured) is skipped by
// the chain and bridged when both neighbours are resolved (criterion.h);
// any other status counts as unresolved. In a chart photograph
// (`chart_photograph`), out_of_view is unmeasured (a photograph frames some
// groups and cuts others), and so is a low_signal element whose m the fit
// cannot pin down (m_undetermined: dust, a scratch or glare over a coarse
// element of a real chart; dev_14's G4E1). Layout mode, which frames the
// whole target it made, counts both as unresolved instead. In both, an
// element whose level step a gain field cannot tell from zero
// (ElementResult::m_scale_undetermined, low_signal) is unmeasured, and an ok
// one that is not resolved only because that step is too uncertain is
// bridged by the optical limit (the detectability limit counts its CNR).
bool is_unmeasured(const ElementResult& r, bool chart_photograph);

// Chart photographs: an element that shows no bars (unresolved `ok`, or
// `aliased`) while the next two finer elements measured in its orientation
// (judged fine to coarse, passing over at most one judged damaged; each
// on the series past the one before, with at most one element between
// them not found at all) are resolved
// with m significantly above its own is `damaged`: a transfer
// function does not rise with frequency, so the loss is local (dust, a
// scratch, a defect of the chart, the blurred edge of the field), not the
// optics'. It is unmeasured: never resolved, bridged by the chain, and its
// note names the finer elements. Call before decide_limits.
void grade_damaged(Measurement& M, const Criterion& criterion);
void decide_limits(Measurement& M, const Criterion& criterion, const DetectabilityCriterion& detectability,
                   bool chart_photograph);

// Why a chart photograph in which nothing is resolved cannot be measured
// (Measurement::problem): where no element was fitted at all and some are
// `clipped`, the clipping; otherwise that even the coarsest element found
// is below the criterion.
std::string unresolved_chart_problem(const std::vector<ElementResult>& elements);

}  // namespace tactres
