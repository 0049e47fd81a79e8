#pragma once
// The level step of a relief over the target (docs/CONVENTIONS.md, "A light
// that varies over the target").
//
// A relief pressed into the gel shows its slope through the shading gain
// E_t / E_n along the bars' axis. Where the light's direction changes over
// the target (a light spot below the gel: its in-plane part points toward
// the spot's centre), the gain changes from place to place, and an element
// normalised by the reference patch's step would read m times the ratio of
// the two gains. The gain is therefore measured where it can be: on the
// patch and on the coarse elements (>= 4 px per bar, and their own fit with
// the step free gives a transfer >= 0.6 at their frequency: the bars' edges
// are resolved), where the fitted level step separates from m. A plane in target mm per
// orientation, weighted by each estimate's error plus a model floor, is
// the field; each element is normalised by it at its own centre, with the
// plane's error at that point in the step's sigma.
//
// Uniform light keeps today's figures exactly: the plane replaces the
// patch's step only when it changes the step by more than
// kUniformTolerance at some measured element AND its gradient is
// significant (> 3 sigma). Otherwise the field is `uniform`.

#include <vector>

#include "tactres/measure/element_pipeline.h"
#include "tactres/measure/measurement.h"

namespace tactres {

// Beyond this relative change of the step somewhere on the target, the
// plane replaces the patch's step (a 10 % step error is a 10 % m error,
// several times the fits' own).
inline constexpr double kUniformTolerance = 0.10;
// Above this spread, the measurement says the light is strongly non-uniform.
inline constexpr double kStronglyNonUniformSpread = 0.5;

struct GainSample {
  Vec2 at_mm;
  double contrast = 0, contrast_sigma = 0;
};

// The plane through `samples` (the patch first when usable), and the choice
// between it and the patch's step (above). `measured_at_mm`: the centres of
// the elements it will be applied to, where the spread is taken. Fewer than
// 4 samples, or samples that do not span both axes, give `uniform`.
GainField fit_gain_field(const std::vector<GainSample>& samples, Vec2 patch_center_mm, const LevelStep& patch,
                         const std::vector<Vec2>& measured_at_mm);

// Layout mode, relief targets: fits each coarse element's level step from
// its sampled profile (element_pipeline.h) and sets `reference`'s two
// fields. Target-mm positions are the jobs' strip centres.
void estimate_gain_fields(const std::vector<ElementJob>& jobs,
                          const std::vector<std::vector<SampledProfile>>& profiles, const TargetLayout& layout,
                          ReferenceResult& reference);

}  // namespace tactres
