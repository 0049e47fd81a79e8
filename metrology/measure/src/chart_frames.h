#pragma once
// Chart mode's geometry (private to chart_jobs.cpp and chart_measure.cpp):
// each detected bar pattern gets its own frame, a PatternFrame
// (camera/plane_map.h) whose plane is the pattern's, in mm of its element;
// the ideal artwork of that plane holds the pattern's own bars and the
// detected patterns near it. The frame is refined on the profile itself
// (shift and scale across the bars), because the profile model has no
// shift: a misplaced pattern reads as blur.

#include <deque>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "tactres/camera/plane_map.h"
#include "tactres/locate/chart_detect.h"
#include "tactres/measure/element_pipeline.h"
#include "tactres/profiles/profile_fit.h"
#include "tactres/profiles/profile_sampler.h"
#include "tactres/targets/coverage.h"
#include "tactres/targets/layout.h"

namespace tactres::chart {

// One detected pattern measured as one orientation of one element.
struct PatternRef {
  int pattern;
  BarOrientation orientation;
  int group, element;
  double lp_per_mm;
  // The found pattern of a partial element (ChartElement::partial): its
  // partner was not found, so nothing checks it as the pair does. It is
  // measured, but it neither scales the frames nor gives the level step.
  bool lone = false;
  double bar_width_mm() const { return 0.5 / lp_per_mm; }
};

// The frame of pattern `p` measured as orientation `o`: plane x along the
// bars of a horizontal-bar pattern, across those of a vertical-bar one.
PatternFrame frame_of(const BarPattern& p, BarOrientation o, double lp_per_mm);

// The image direction across the bars (the profile's u) of a frame whose
// pattern has orientation `o`.
inline Vec2 across_dir(const PatternFrame& f, BarOrientation o) {
  return o == BarOrientation::vertical_bars ? f.x_dir : f.y_dir();
}

// Owns the frames and artworks that the element pipeline's placements point
// to; a deque never moves what it holds.
class PlacementStore {
 public:
  PlacementStore(const cv::Mat& luminance, const ChartDetection& detection, double clip_level)
      : lum_(luminance), D_(detection), clip_(clip_level) {}

  // A placement of `r` in frame `f`, kept for the store's lifetime.
  ElementPlacement place(const PatternRef& r, const PatternFrame& f, const ProfileSamplingOptions& so);
  // The artwork a placement of this store points to, shared, so that a live
  // sequence's track can keep it after the store is gone (the neighbours sit
  // at the same plane mm while the chart moves as a whole).
  std::shared_ptr<const IndexedArtwork> shared_artwork(const IndexedArtwork* artwork) const;
  // The strip of `r` seen through frame `f` (the ideal complemented for a
  // negative chart), without keeping the placement.
  SampledProfile sample(const PatternRef& r, const PatternFrame& f, const ProfileSamplingOptions& so) const;
  // `so` with the margin beyond the outer bars narrowed, in steps down to
  // the least the profile model needs (half a bar), until the strip is in
  // the image: a single element filling a microscope frame leaves no room
  // for the usual margin.
  ProfileSamplingOptions fitted_in_view(const PatternRef& r, const PatternFrame& f, ProfileSamplingOptions so) const;
  // The frame moved onto the pattern across the bars (by correlation with
  // the ideal pattern, within 0.6 bar). Callers decide whether a predicted
  // pattern is recentred (chart_jobs.cpp: only as a second placement).
  PatternFrame recentre(const PatternRef& r, PatternFrame f, const ProfileSamplingOptions& so) const;
  // Frame `f` moved one period across the bars, where the triplet stands
  // there rather than at `f` (period_slip, on a strip sampled wide enough
  // to show both places), and recentred; none otherwise, and none where
  // the wider strip does not fit in the image.
  std::optional<PatternFrame> unslipped(const PatternRef& r, const PatternFrame& f,
                                        const ProfileSamplingOptions& so) const;

 private:
  const cv::Mat& lum_;
  const ChartDetection& D_;
  double clip_;
  std::deque<PatternFrame> frames_;
  std::deque<std::shared_ptr<const IndexedArtwork>> artworks_;
};

// Whether the triplet's bar and gap windows, with the ground beyond its
// outer bars counted as gaps, match profile `d` (bars of width `w_mm`)
// clearly better one period (2 w) along u than at its centre: +1 or -1,
// the way along u; 0 if not. The profile must reach 5.25 w either way.
int period_slip(const ProfileData& d, double w_mm, bool light);

// `fo` with the pattern's bars free to move along u within a quarter of a
// bar of width `w_mm` (ProfileFitOptions::fit_shift).
ProfileFitOptions with_free_shift(ProfileFitOptions fo, double w_mm);
// Whether a fit made with_free_shift(.., w_mm) placed the bars: usable,
// the shift's sigma under a tenth of a bar, and short of the range's edge
// (where Ceres' covariance, blind to the bound, still reads small).
bool shift_placed(const ProfileFit& f, double w_mm);

// The shift the profile model itself prefers, to a small fraction of a bar
// of width `w_mm`; returns the profile with its ideal moved, and the shift
// (mm along u) in `shift_mm` when given.
ProfileData refine_shift_by_fit(const ProfileData& d, const ProfileFitOptions& fo, double w_mm,
                                double* shift_mm = nullptr);

// The profile's ideal pattern moved by `shift_mm` along u (a negative
// chart's complement constant stays).
ProfileData shifted_ideal(const ProfileData& d, double shift_mm);

// One pattern's profile for shared_shifts_px: its bar width, and the mm
// along its u that one px along the patterns' common direction is (signed:
// a frame's u may point either way).
struct ShiftSample {
  const ProfileData* data = nullptr;
  double bar_mm = 0;
  double u_mm_per_px = 0;
};

// For each pattern, the shift (px along the patterns' common direction,
// within +-max_px, in steps of 0.1 px) that the other patterns share best:
// the sum of their bar-against-gap contrasts (bars and gaps of the triplet
// only) is highest there, so that a pattern's own noise cannot place it.
// nullopt unless the whole group shows its bars there clearly (over each
// profile's rms about its trend), two patterns or more of it on their own
// (also by 4 of the bins' standard errors), and far better than unshifted
// (chart_frames.cpp).
std::vector<std::optional<double>> shared_shifts_px(const std::vector<ShiftSample>& samples, bool light,
                                                    double max_px);

// The scale of the pattern (relative to the frame's) that the profile model
// prefers; nullopt unless the pattern pins it down.
std::optional<double> fit_scale(const ProfileData& d, const ProfileFitOptions& fo);

// A quantity over the image: v = c0 + c1 x + c2 y (pixels), fitted by
// least squares (a constant, their mean, from fewer than 4 samples).
struct PlaneField {
  bool valid = false;
  double c[3] = {0, 0, 0};
  double at(Vec2 p) const;
};
PlaneField fit_plane_field(const std::vector<std::pair<Vec2, double>>& samples);

// Image scale across the bars over the chart, per orientation:
// ln(px/mm) a plane field, fitted to the patterns whose scale the profile
// model pinned down. A plane seen in mild perspective has a smoothly
// varying scale, and the coarse patterns fix it far better than a fine
// pattern near the limit can fix its own.
struct ScaleField {
  bool valid = false;
  PlaneField log_scale;
  double at(Vec2 p) const;
  // The field's px/mm at p, or `own_px_per_mm` (a pattern's own period's)
  // where the field strays from it by more than kMaxLogDeviation. Far from
  // its samples a plane's tilt is unconstrained (samples along one column:
  // a JPEG copy of dev_14 put group 4's V patterns at 0.07 px per bar,
  // against their own 12). Blur overstates a fine pattern's binarised
  // period by up to 2/3 of a step of the series (8 %); the field corrects
  // that and a lens's slow change of scale, not a quarter.
  static constexpr double kMaxLogDeviation = 0.22;
  double at_or(Vec2 p, double own_px_per_mm) const;
};
ScaleField fit_scale_field(const std::vector<std::pair<Vec2, double>>& samples);

}  // namespace tactres::chart
