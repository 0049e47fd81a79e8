#pragma once
// Detectability: whether the bars stand out of the noise in one frame,
// beside whether the optics transfer them (criterion.h). Shared by the truth
// file (simulate) and the measurement, like the criterion, so that both
// sides define it identically (docs/CONVENTIONS.md, "Two limits").
//
// Rose model (A. Rose, Vision: Human and Electronic, 1973, ch. 1): an object
// of contrast dI covering N pixels, each with noise sigma, is seen in a
// single frame when
//
//   CNR = dI sqrt(N) / sigma >= k,   k = 5 by default (Rose's value for
//                                    certain detection).
//
// For a bar triplet:
//   dI     the peak-to-peak of the bars' fundamental in image units,
//          (4 / pi) m(f) |c| B0 D(f): B0 the local ground level, c the level
//          step (albedo: ink / ground - 1; shading: the slope response, mm),
//          D = 1 for albedo and 2 pi f for shading (the image of a relief is
//          its slope: d/du multiplies the fundamental by 2 pi f). Near the
//          limit the harmonics are gone and this is the bar/gap difference
//          the image shows;
//   N      the pixels one bar covers: its width times its length (5 widths)
//          in pixels;
//   sigma  the per-pixel noise at the element's mean level: B0 (1 + c / 2)
//          for albedo (bars and gaps alike), B0 for shading.
//
// The detectability limit of an orientation is the finest element such that
// it and every coarser element are detectable (CNR >= k, and CNR above zero
// by z standard errors, or, on a chart photograph, the bars shown above
// zero by their gaps' dips: CnrPoint::shown_by_dips), with the same chain
// rules as the optical limit (unmeasured elements are bridged). Its interpolated value is where CNR
// crosses k, ln CNR linear in f^2 between the last detectable element and
// the next (exact for a Gaussian MTF up to the slowly varying sqrt(N) ~ 1/f,
// whose curvature moves the crossing by < 0.1 % over an element step).
//
// The reported resolution limit is the coarser of the optical and the
// detectability limit; `limited_by` says which.

#include <optional>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "tactres/profiles/criterion.h"
#include "tactres/profiles/profile_fit.h"

namespace tactres {

struct DetectabilityCriterion {
  double k = 5.0;               // Rose threshold on the CNR, [1, 100]
  double significance_z = 2.0;  // CNR must exceed z standard errors above 0

  void validate() const;  // throws std::invalid_argument
};

// dI above, in the units of `ground_level`; 0 for a non-finite input.
double bar_signal_ptp(double m, double contrast, double ground_level, Signature signature, double lp_per_mm);
// A light that turns over the target changes a relief's level step across
// an element: c(u) = c + c' u about its centre (u across the bars, mm).
// Each bar then shows its own dI; the step a Rose CNR takes is their RMS
// over the triplet's width (a matched filter over the bars), not the step
// at the centre, which vanishes where the light's in-plane part across the
// bars changes sign although the outer bars still shade. The triplet spans
// 5 bar widths (3 bars, 2 gaps): |u| <= 1.25 / f. Returns
// sign(c) sqrt(c^2 + (c' U)^2 / 3), U the half-width; c when c' = 0.
double triplet_half_width_mm(double lp_per_mm);
double rms_step_over_triplet(double contrast, double contrast_slope_per_mm, double lp_per_mm);
// The level whose noise counts: B0 (1 + c / 2) for albedo, B0 for shading.
double element_mean_level(double contrast, double ground_level, Signature signature);
// Pixels one bar covers: bar width in px times its length, kUsafBarLengthInWidths
// widths scaled by the image's along/across anisotropy.
double pixels_per_bar(double px_per_bar_across, double along_over_across_scale);
// dI sqrt(N) / sigma; 0 when sigma or N is not positive.
double rose_cnr(double signal_ptp, double pixels_per_bar, double noise_sd);

// One element's CNR, in ascending frequency order within an orientation.
struct CnrPoint {
  int group = 0, element = 1;
  double lp_per_mm = 0;
  double cnr = 0, cnr_sigma = 0;  // cnr_sigma 0 for exact truth
  bool usable = true;             // false: graded status other than ok (never detectable)
  bool unmeasured = false;        // skipped by the chain (implies !usable)
  double shot_fraction = 1.0;     // share of the noise variance that scales with the light (shot noise)
  bool shown_by_dips = false;     // the bars shown above zero by their gaps (MPoint::shown_by_dips)
};

bool is_detectable(const CnrPoint& p, const DetectabilityCriterion& c);
// `points` sorted by ascending lp_per_mm.
Limit find_detectability_limit(const std::vector<CnrPoint>& points, const DetectabilityCriterion& c);

// The exposure factor g that brings a CNR of `cnr` to `k`, when a share
// `shot_fraction` of the noise variance is shot noise (scales with g) and
// the rest read noise (does not): g^2 cnr^2 = k^2 (1 - phi + phi g).
// Below 1: light to spare. 0 for a CNR of 0 (no light is enough).
double exposure_factor_for_cnr(double cnr, double shot_fraction, double k);

// "Light needed": the exposure factor at which the detectability limit
// would reach the optical limit, from the CNR at the optical limit
// (interpolated as ln CNR linear in f^2 between the elements around its
// interpolated value, or the discrete limit element's own). Absent when the
// optical limit resolves nothing or its elements' CNR is not known.
std::optional<double> light_needed_factor(const std::vector<CnrPoint>& points, const Limit& optical,
                                          const DetectabilityCriterion& c);

enum class LimitingFactor { optics, light_noise };
const char* to_string(LimitingFactor f);  // "optics", "light/noise"

// One orientation's two limits and the one reported first.
struct LimitBreakdown {
  Limit optical, detectability;
  LimitingFactor limited_by = LimitingFactor::optics;
  std::optional<double> light_needed;  // light_needed_factor()
  const Limit& reported() const { return limited_by == LimitingFactor::optics ? optical : detectability; }
};
// The coarser of the two: compared by the discrete element, then by the
// interpolated value; a tie goes to the optics.
LimitBreakdown combine_limits(const Limit& optical, const Limit& detectability);

// One orientation's limits from the m and the CNR points of its elements,
// each in any order: the optical limit under `c`, the detectability limit
// under `d`, the coarser of the two, and the light needed. The truth and the
// measurement both decide by it.
LimitBreakdown decide_breakdown(std::vector<MPoint> m, std::vector<CnrPoint> cnr, const Criterion& c,
                                const DetectabilityCriterion& d);

// limit_to_json(reported) plus "limited_by", "optical": {...} and
// "detectability": {..., "k"}: a reader of the plain limit fields gets the
// reported limit.
nlohmann::json breakdown_to_json(const LimitBreakdown& b, const DetectabilityCriterion& c);

}  // namespace tactres
