#pragma once
// Chart mode's element jobs (private to chart_measure.cpp): the frame each
// pattern is measured in, and the placements its fit chooses between
// (chart_frames.h holds the geometry they are made of).

#include <utility>
#include <vector>

#include "chart_frames.h"
#include "tactres/locate/chart_detect.h"
#include "tactres/measure/element_pipeline.h"
#include "tactres/measure/measure.h"

namespace tactres::chart {

// Per profile the fit's shift search ran on, the shift it chose (mm along
// u).
using ShiftLog = std::vector<std::pair<const ProfileData*, double>>;

// One frame per ref: where its pattern was found (or predicted), at the
// image scale across the bars that the coarse patterns' profiles give,
// smoothed over the chart.
std::vector<PatternFrame> pattern_frames(const ChartDetection& D, const std::vector<PatternRef>& refs,
                                         const PlacementStore& store, const MeasureOptions& mo);

// The nested patterns of each group and orientation (four or more) moved
// across their bars, each by the shift the others' profiles agree on
// (shared_shifts_px); the other frames are left as they are.
void shift_predicted_groups(const ChartDetection& D, const std::vector<PatternRef>& refs,
                            std::vector<PatternFrame>& frames, const PlacementStore& store,
                            const MeasureOptions& mo);

// One job per ref, in the order of `refs`: the frame centred on the data
// and a second placement where that differs. `shifts`, if given, collects
// the fit's shift per profile (a live sequence's track keeps them).
std::vector<ElementJob> pattern_jobs(const ChartDetection& D, const std::vector<PatternRef>& refs,
                                     const std::vector<PatternFrame>& frames, PlacementStore& store,
                                     const MeasureOptions& mo, ShiftLog* shifts);

// Jobs of found patterns graded (`graded[j]`, on placement
// `graded_placement[j]`) ok with one gap flat, whose triplet stands one
// period along the column (PlacementStore::unslipped): that frame is added
// as another placement. Returns how many were; their jobs must be sampled
// and graded again.
int add_unslipped_placements(const ChartDetection& D, const std::vector<PatternRef>& refs,
                             std::vector<ElementJob>& jobs, PlacementStore& store,
                             const std::vector<ElementResult>& graded, const std::vector<size_t>& graded_placement);

}  // namespace tactres::chart
