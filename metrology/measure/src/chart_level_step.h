#pragma once
// The chart's level step (private to chart_measure.cpp): in chart mode there
// is no reference patch, so the step between ink and ground that the
// profile model scales each element by comes from the coarsest elements
// themselves.

#include <optional>
#include <string>
#include <vector>

#include "chart_frames.h"
#include "tactres/measure/element_pipeline.h"
#include "tactres/measure/measurement.h"
#include "tactres/profiles/profile_fit.h"
#include "tactres/profiles/profile_sampler.h"

namespace tactres::chart {

// The step read off a profile's plateaus, with no blur model: the ground
// level is a line fitted to the bins in the middle of the gaps and margins,
// the ink level is taken in the middle of the bars, and
// contrast = mean(ink / ground) - 1 (the model's c, profile_fit.h). A
// plateau bin lies at least a quarter bar width inside one shape, so blur
// up to about that width leaves it alone. Its sigma is the spread of the
// bars' ratios (the bins' own standard errors are far too small for what
// differs from bar to bar: dust, print density). nullopt when fewer than
// two bars or two ground stretches have plateau bins.
std::optional<LevelStep> plateau_level_step(const ProfileData& d, double bar_width_mm);

// The level step per orientation, as the reference patch gives it in layout
// mode (see chart_level_step.cpp). False if neither orientation has one.
// `note` says where a step was taken from the plateaus instead of the fit
// or, when false, why there is no step (for the measurement's problem).
bool chart_level_steps(const ChartDetection& D, const std::vector<PatternRef>& refs,
                       const std::vector<ElementJob>& jobs, const std::vector<std::vector<SampledProfile>>& profiles,
                       const MeasureOptions& mo, ReferenceResult& ref, std::string* note);

}  // namespace tactres::chart
