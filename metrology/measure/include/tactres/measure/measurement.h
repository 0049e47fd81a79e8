#pragma once
// What a measurement of one capture is (layout mode, measure.h, and chart
// mode, chart_measure.h, fill the same types): its options, each element's
// graded result, the level step m is scaled by, and the limits.
//
// Every failure is data: an unusable capture has usable = false and a
// problem a user can act on; an element that cannot be measured has a
// graded status and is never called resolved. No field is ever NaN.

#include <array>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "tactres/camera/transfer_curve.h"
#include "tactres/locate/fiducials.h"
#include "tactres/locate/pose.h"
#include "tactres/profiles/criterion.h"
#include "tactres/profiles/detectability.h"
#include "tactres/profiles/profile_fit.h"
#include "tactres/profiles/profile_sampler.h"
#include "tactres/targets/layout.h"

namespace tactres {

enum class ElementStatus {
  ok,                    // fitted; resolved or not by the criterion
  low_signal,            // the fit cannot pin m down (m_sigma too large)
  clipped,               // saturated or black pixels in the profile
  aliased,               // the data do not show the expected bars (wrong period or count)
  below_sampling_limit,  // too few pixels per bar to measure
  out_of_view,           // the element's strip is not fully inside the image
  fit_failed,            // the solver failed or the fit is degenerate
  damaged,               // shows no bars where the two finer elements do (dust, a scratch, the field's edge)
};
const char* to_string(ElementStatus s);

enum class Preset { fast, balanced, precise };
const char* to_string(Preset p);
Preset preset_from_string(const std::string& s);  // throws std::invalid_argument

struct MeasureOptions {
  Preset preset = Preset::balanced;
  ProfileSamplingOptions sampling;
  bool fit_psf_shape = true;        // fit beta (PSF shape); false: Gaussian
  int pose_boundary_points = 48;    // disc outline points in the pose model
  double max_bins_per_bar = 10;     // coarse elements: bins no finer than w / this
  // The profile bin for an element of `px_per_bar` pixels per bar: the
  // preset's bin, no finer than max_bins_per_bar per bar (coarse elements),
  // and no coarser than half a bar (an element near the sampling floor
  // binned by whole pixels loses the sub-pixel phases that pin its edges:
  // fast's 2-sigma coverage fell to 92 % when the floor came down to 1.25).
  double bin_px_for(double px_per_bar) const;
  Criterion criterion;
  DetectabilityCriterion detectability;
  double min_px_per_bar = 1.25;     // below: below_sampling_limit (Kell factor 0.8 of Nyquist); on a chart
                                    // photograph unless its three bars plainly show (element_grading.h)
  double aliasing_chi2 = 16;        // reduced chi^2 above which a fine element is aliased
  double max_m_sigma = 0.25;        // above: low_signal
  double max_patch_chi2 = 50;       // above: the capture does not match the layout
  double transfer_check_chi2 = 10;  // patch reduced chi^2 above which other transfer curves are tried
  double poor_fit_chi2 = 25;        // an ok element above this gets a note (its sigma is already widened)
  std::string signature = "auto";   // auto | albedo | shading

  static MeasureOptions for_preset(Preset p);
  void validate() const;  // throws std::invalid_argument
};

struct ElementResult {
  int group = 0, element = 1;
  BarOrientation orientation = BarOrientation::horizontal_bars;
  double lp_per_mm = 0, px_per_bar = 0;
  double m = 0, m_sigma = 0;  // 0 when the status is not ok
  double beta = 0, chi2_reduced = 0;
  // Detectability (profiles/detectability.h), set when the status is ok:
  // the bars' peak-to-peak signal and the per-pixel noise at the element's
  // mean level, both in linear image units; the pixels one bar covers; the
  // Rose CNR and its standard error.
  double signal = 0, noise_sd = 0, bar_pixels = 0;
  double mean_level = 0;  // the level noise_sd is taken at (albedo: halfway between bar and gap)
  double cnr = 0, cnr_sigma = 0;
  double noise_shot_fraction = 0;  // share of noise_sd^2 that scales with the light (shot noise)
  ElementStatus status = ElementStatus::fit_failed;
  // low_signal because the fit cannot pin m down (m_sigma above the
  // grading's limit): the data say nothing about this element, unlike a fit
  // that drives m to 0 (no modulation left).
  bool m_undetermined = false;
  // The level step at the element, from a gain field near a line where the
  // light runs along the bars, is known too poorly to scale m: low_signal
  // when it cannot be told from zero (no fit; bridged by both limits), or
  // ok with its error above the grading's limit on its own (bridged by the
  // optical limit unless resolved anyway; its CNR counts). The measurement
  // does not know whether the bars shade there (element_grading.h).
  bool m_scale_undetermined = false;
  // ok, but one gap of its triplet shows no dip while the other clearly
  // does (profiles/gap_dips.h): two bars are seen, not three, so it is
  // never resolved, whatever m reads.
  bool gap_flat = false;
  // ok, read from its gaps' dips rather than the profile model: the model
  // cannot measure its bars (clipped, a misfit, or m_sigma too large), yet
  // all three show (element_grading.h).
  bool m_from_dips = false;
  // ok, on a chart photograph of printed bars whose gaps both dip: m read
  // model-free from the shallower dip (element_grading.h), beside the fit's
  // m; dips_m_sigma 0 where none was read. Where that reading is itself
  // resolved, the bars count as significantly above zero (criterion.h,
  // MPoint::shown_by_dips) even when a poor fit widens m_sigma past it.
  double dips_m = 0, dips_m_sigma = 0;
  bool resolved = false;
  bool detectable = false;
  std::string note;  // why a graded or poorly fitting element is what it is; empty if nothing to say
  std::array<Vec2, 4> outline_px{};
  bool outline_valid = false;
  // The middle of the strip its profile was sampled in, image px (the
  // element's place; meaningful where outline_valid).
  Vec2 strip_center_px() const {
    return 0.25 * (outline_px[0] + outline_px[1] + outline_px[2] + outline_px[3]);
  }

  // An element not yet measured: what it is, and its scale in the image.
  static ElementResult of(int group, int element, BarOrientation orientation, double lp_per_mm, double px_per_bar) {
    ElementResult r;
    r.group = group;
    r.element = element;
    r.orientation = orientation;
    r.lp_per_mm = lp_per_mm;
    r.px_per_bar = px_per_bar;
    return r;
  }
};

// The level step across bars of one orientation (the full bar-to-gap step
// that m is measured against), from the reference patch in layout mode or
// from the chart's coarse elements in chart mode.
struct LevelStep {
  double contrast = 0, contrast_sigma = 0;
  double chi2_reduced = 0;  // of the fit that measured it; 0 if none
  // Usable as a scale: it stands out of its own error and is not zero. A
  // relief lit along one axis has none across the other.
  bool usable() const { return distinct_from_zero(5); }
  // More than k sigma away from zero (and not zero).
  bool distinct_from_zero(double k) const { return std::abs(contrast) > k * contrast_sigma && std::abs(contrast) > 1e-4; }
};

// The level step of one orientation over the target (layout mode, relief
// targets; gain_field.h, docs/CONVENTIONS.md "A light that varies over the
// target"): a relief's step is the shading gain E_t / E_n along the bars'
// axis, which a light that changes direction over the target changes from
// place to place. `plane`: contrast(p) = contrast + gradient . (p - origin),
// estimated from the patch and the coarse elements; otherwise the patch's
// step holds everywhere (uniform).
struct GainField {
  bool plane = false;
  Vec2 origin_mm;                                  // the patch centre
  double contrast = 0;                             // at origin_mm
  double gradient_x_per_mm = 0, gradient_y_per_mm = 0;
  std::array<double, 6> covariance{};              // upper triangle of (c, gx, gy)
  int samples = 0;                                 // patch + coarse elements used
  double chi2_reduced = 0;                         // of the plane
  // Where the plane misfits (chi2_reduced > 1: a curved field), how far one
  // point's step departs from it beyond its own error: (chi2_reduced - 1)
  // times the samples' mean variance. at() adds it, so a step read off the
  // plane carries a prediction interval, not only the plane's own error.
  double misfit_var = 0;
  // Largest |contrast(element) / contrast(patch) - 1| over the measured
  // elements' centres (0 when uniform); > 0.5 is noted as strongly non-uniform.
  double spread = 0;
  LevelStep at(Vec2 p_mm, const LevelStep& patch) const;
};

struct ReferenceResult {
  bool usable = false;
  std::string problem;
  Signature signature = Signature::albedo;
  // Per orientation: across y for horizontal bars, across x for vertical
  // bars (JSON: contrast_y / contrast_x).
  LevelStep horizontal_bars, vertical_bars;
  const LevelStep& step(BarOrientation o) const {
    return o == BarOrientation::horizontal_bars ? horizontal_bars : vertical_bars;
  }
  LevelStep& step(BarOrientation o) { return o == BarOrientation::horizontal_bars ? horizontal_bars : vertical_bars; }
  GainField horizontal_field, vertical_field;  // uniform unless grade_jobs found otherwise
  const GainField& field(BarOrientation o) const {
    return o == BarOrientation::horizontal_bars ? horizontal_field : vertical_field;
  }
  // The step at a target point: the field's, or the patch's when uniform.
  LevelStep step_at(BarOrientation o, Vec2 p_mm) const { return field(o).at(p_mm, step(o)); }
  bool layout_mismatch = false;   // refused: the model cannot describe the patch where the layout puts it
  std::vector<Vec2> outline_px;   // corners of the two patch strips in the image
};

struct Measurement {
  bool usable = false;
  std::string problem;  // why not usable, and what to do
  int image_width = 0, image_height = 0;
  std::string camera_source;       // the model file, or "pinhole fitted from fiducials"
  bool distortion_corrected = false;
  FiducialSearchResult fiducials;
  PoseResult pose;
  ReferenceResult reference;
  TransferDecision transfer;    // the curve the capture was measured with, and why
  TransferCheck transfer_check; // what the reference patch said about that curve
  std::vector<std::string> warnings;  // for people: what to check although the capture was measured
  std::vector<ElementResult> elements;
  // The reported limit per orientation (the coarser of the optical and the
  // detectability limit), and both parts with the factor that limits.
  Limit horizontal, vertical;
  LimitBreakdown horizontal_parts, vertical_parts;
  const LimitBreakdown& parts(BarOrientation o) const {
    return o == BarOrientation::horizontal_bars ? horizontal_parts : vertical_parts;
  }
  double nyquist_h_lp_per_mm = 0, nyquist_v_lp_per_mm = 0;
  std::vector<std::pair<std::string, double>> stage_seconds;
};

}  // namespace tactres
