#pragma once
// Chart mode in a live sequence (private to chart_measure.cpp): how the
// chart has moved in the image since the frame its track was made on, from
// the coarse "anchor" patterns (chart_measure.h, ChartTrack). Each anchor's
// profile now is matched with its profile on that frame; it says where the
// chart is across its bars only, so one observation is one line:
// n . M(p_refit) = n . p_now.

#include <optional>
#include <utility>
#include <vector>

#include "tactres/measure/chart_measure.h"

namespace tactres::chart {

// A profile's mean level per filled bin of its fit window: (u mm, level),
// u ascending.
using LevelProfile = std::vector<std::pair<double, double>>;
LevelProfile level_profile(const ProfileData& d);

// The shift s (mm along u) such that `now` best matches `reference` moved by
// s (least squares, with a gain and an offset free: the light may change),
// searched within +-reach_mm. The reference is interpolated linearly at the
// bins' mean positions, so s is not tied to the bin grid; a symmetric blur
// that changed between the two (focus) does not move the optimum. Nullopt
// when the best lies at the end of the reach or the two overlap too little.
std::optional<double> match_shift_mm(const LevelProfile& now, const LevelProfile& reference, double reach_mm);

struct MotionSample {
  Vec2 from_px;      // the pattern's centre on the refit frame
  Vec2 across;       // unit image direction across its bars, now
  double across_px;  // where its centre lies along `across` now: across . p_now
};

struct MotionFit {
  bool ok = false;
  ChartMotion motion;
  double rms_px = 0;   // of the samples kept
  int samples_used = 0;
  bool affine = false;  // false: a similarity (too few samples, or too few directions and places for an affine)
};

// Least squares, dropping the worst sample while it misses by more than
// `outlier_px` (a pattern locked onto the wrong bar, dust): an affine map
// when at least 8 samples pin all six parameters down, a similarity (four)
// otherwise; not ok with fewer than 4 samples left.
MotionFit fit_chart_motion(std::vector<MotionSample> samples, double outlier_px);

}  // namespace tactres::chart
