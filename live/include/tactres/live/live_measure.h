#pragma once
// One frame after another of a live sequence (`tactres watch`,
// docs/LIVE.md): each frame is measured like `tactres measure` measures a
// capture, with what the frames before established carried over while it
// still holds.
//
// Layout mode:
//  - tracking: the fiducials are searched near where the frame before had
//    them, and the pose starts from its pose; when that finds nothing, the
//    whole frame is searched (measure.h, FramePlan);
//  - the reference patch is fitted again every `refit_every` frames, when
//    the frame's mean level has changed by more than `light_change` since
//    the last fit, and after any frame that could not be measured;
//  - `near_limit`: only the elements within `near_limit_span` elements of
//    the limit are fitted; the others keep their last fitted result, and
//    every frame that refits the patch fits all of them.
// Chart mode (chart_measure.h, ChartTrack): a tracked frame moves the
// patterns of the last frame measured from scratch with the chart (the
// coarse patterns' profiles, matched with theirs on that frame, give its
// motion), keeps that frame's level steps and fits each element once;
// `near_limit` fits only the elements within `near_limit_span` of the last
// limit (and the watched one) and carries the others. The chart is
// detected and measured from scratch every `refit_every` frames, on a
// change of light, and whenever the tracked frame is not usable (the chart
// moved too far, the limit ran past the finest element detected, or
// nothing is resolved).

#include <optional>
#include <string>

#include "tactres/camera/camera_model.h"
#include "tactres/live/frame_source.h"
#include "tactres/measure/chart_measure.h"
#include "tactres/measure/measure.h"
#include "tactres/targets/layout.h"

namespace tactres {

enum class LiveElements { all, near_limit };

struct LiveOptions {
  MeasureOptions measure;          // the preset's
  bool chart = false;              // a standard USAF-1951 chart instead of a layout
  ChartDetectOptions chart_detect;
  bool tracking = true;            // false: every frame from scratch
  int refit_every = 30;            // frames, [1, 100000]
  double light_change = 0.05;      // relative change of the mean level, (0, 1]
  LiveElements elements = LiveElements::all;
  int near_limit_span = 3;         // elements on each side of the limit, [1, 30]
  void validate() const;           // throws std::invalid_argument
};

struct LiveFrameResult {
  long index = 0;
  std::string name;
  double time_s = 0;
  bool measured = false;       // usable measurement (limits below are meaningful)
  std::string problem;         // why not
  Measurement measurement;
  bool relative = false;       // chart mode, group unknown
  bool tracked = false;        // found near the frame before (layout) / moved with the chart from it (chart)
  bool refit = false;          // reference patch fitted / chart detected and measured from scratch on this frame
  double analysis_ms = 0;      // wall clock of the measurement, decode excluded
};

class LiveMeasurer {
 public:
  // `layout` is null in chart mode; `camera` may be null (a pinhole is fitted).
  LiveMeasurer(const LiveOptions& options, const TargetLayout* layout, const CameraModel* camera);
  LiveFrameResult measure(const Frame& frame);
  // An element fitted on every frame whatever `elements` says (the one a
  // person watches): group and element, per orientation.
  void always_fit(BarOrientation o, int group, int element);

 private:
  LiveFrameResult measure_layout(const LoadedImage& image, bool refit);
  LiveFrameResult measure_chart_frame(const LoadedImage& image, bool refit);
  FramePlan plan_for(bool refit) const;
  ChartFramePlan chart_plan_for(bool refit) const;
  // Whether a near-limit frame fits this element: the watched one
  // (always_fit), or one within `near_limit_span` elements of the last
  // limit in its orientation.
  bool fit_near_limit(int group, int element, double lp_per_mm, BarOrientation o, double coarsest_lp_per_mm) const;

  LiveOptions options_;
  const TargetLayout* layout_;
  const CameraModel* camera_;
  std::optional<LayoutTrack> track_;
  std::optional<ChartTrack> chart_track_;
  std::vector<ElementResult> last_elements_;  // all elements of the last usable layout frame
  Limit last_h_, last_v_;                     // of the last usable frame, either mode
  std::optional<std::pair<int, int>> always_h_, always_v_;
  int frames_since_refit_ = 0;
  double level_at_refit_ = 0;
};

// A frame's reported limit for people: "G2E4 5.69 lp/mm" (interpolated
// where there is one; "x" the largest element's frequency when the chart's
// group is unknown), "none resolved", or "-" for a frame not measured.
std::string limit_label(const LiveFrameResult& r, BarOrientation o);

// The mean of the finite pixels on a grid of every 8th pixel: the frame's
// light level, cheap enough for every frame.
double frame_level(const cv::Mat& luminance);

// Where an element of `lp_per_mm` stands from `limit` in elements (1/6 octave),
// for the near-limit choice. With nothing resolved, counted from the
// coarsest element's frequency.
double elements_from_limit(double lp_per_mm, const Limit& limit, double coarsest_lp_per_mm);

}  // namespace tactres
