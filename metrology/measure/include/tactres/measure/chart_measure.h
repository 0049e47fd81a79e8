#pragma once
// Measurement of a standard USAF-1951 chart found by detect_chart(): the
// same profiles, Ceres fits, m(f), statuses, criterion and output schema as
// layout mode (measure.h), with the geometry taken from the detection
// instead of fiducials and a layout file.
//
// - Every detected pattern gets its own frame: a pinhole view whose pose
//   maps a local target plane (mm of the anchored group; relative mm when
//   unanchored) onto the pattern in the image. Profiles are sampled from
//   the original image through that view (profile_sampler.h), never from a
//   resampled copy. The frame is refined on the profile itself (shift and
//   scale across the bars, by correlation with the ideal pattern), because
//   the profile model has no shift: a misplaced pattern would read as blur.
// - The ideal strip holds the pattern's own bars and every other detected
//   pattern near it, so a neighbour's blur is modelled, not ignored.
// - The contrast scale (what the reference patch is in layout mode) comes
//   from the coarsest element in view with at least 3 px per bar, fitted
//   with free contrast: its bar tops and gaps show the full level step.
// - Negative charts (light bars) are fitted with the complement pattern,
//   1 - S(u), so the model is the same as for dark bars.
// - Elements of which only one pattern was found (ChartDetection::partial):
//   the found pattern is measured (it neither scales the frames, gives the
//   level step nor anchors a live track: no partner confirms it); the
//   missing one gets a status, not a guess: out_of_view when it lies
//   outside the image, fit_failed when it lies inside but was not found;
//   never resolved, and the limit runs across it. Elements partly out of
//   the image are out_of_view; m(f) is m(f) whether or not the chart is
//   anchored.
// - Grading and the limits are layout mode's own code (element_grading.h).

#include <functional>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "tactres/camera/image_io.h"
#include "tactres/camera/plane_map.h"
#include "tactres/locate/chart_detect.h"
#include "tactres/measure/measure.h"
#include "tactres/profiles/profile_sampler.h"
#include "tactres/targets/coverage.h"

namespace tactres {

struct ChartMeasureOptions {
  MeasureOptions measure;
  ChartDetectOptions detect;
  void validate() const;  // throws std::invalid_argument
};

struct ChartMeasurement {
  Measurement measurement;  // same struct (and JSON/CSV writers) as layout mode
  ChartDetection detection;
};

ChartMeasurement measure_chart(const LoadedImage& image, const ChartMeasureOptions& options);

// The measurement of a chart already detected (by detect_chart on this
// image, or on a frame before it in a live sequence: each pattern's frame is
// refined on its own profile, so a chart that moved by a fraction of a bar
// is still measured where it is). measure_chart = detect_chart + this.
ChartMeasurement measure_chart_detected(const LoadedImage& image, ChartDetection detection,
                                        const ChartMeasureOptions& options);

// ---------------------------------------------------------------------------
// One frame of a live sequence (live/, `tactres watch --chart`): the
// measurement of a chart that a frame before measured from scratch (its
// "refit": detect_chart and measure_chart_detected), carried over while the
// chart only drifts. What the refit established is kept: each pattern's
// frame where the profile model centred it, its ideal artwork, its strip,
// and the level steps. A tracked frame then
//  - finds how the chart moved since the refit: each coarse "anchor"
//    pattern's profile is matched with its profile on the refit (one
//    correlation each), and an affine map of the image (a similarity with
//    few anchors) is fitted to their shifts;
//  - moves every pattern's frame with that map (its centre, bar direction
//    and scale), so a fine pattern is placed by the whole chart's motion,
//    as precisely as its own fitted centre was on the refit, not by its own
//    faint bars;
//  - fits each element it measures once, centred where the refit's fit
//    centred it in its frame (no shift search, no second placement), with
//    the refit's level steps;
//  - optionally fits only the elements the plan accepts (those near the
//    limit) and carries the others' last results.
// It fails (a usable == false measurement; the caller measures from
// scratch) when too few anchors can be matched or they disagree (the chart
// moved more than most anchors' bar width between frames, or left the
// view), and when the limit runs past the finest element the refit found.

// How the chart moved in the image since the refit: pixel p on the refit
// frame is at linear * p + offset_px now.
struct ChartMotion {
  double linear[4] = {1, 0, 0, 1};  // row major 2x2
  Vec2 offset_px{0, 0};
  Vec2 apply_linear(Vec2 d) const { return {linear[0] * d.x + linear[1] * d.y, linear[2] * d.x + linear[3] * d.y}; }
  Vec2 apply(Vec2 p_px) const { return apply_linear(p_px) + offset_px; }
  // A pattern's frame moved with the chart: its centre mapped, the
  // direction across its bars (`bars` says which plane axis that is) turned
  // and its scale stretched as the map does there.
  PatternFrame apply(const PatternFrame& f, BarOrientation bars) const;
};

struct ChartTrack {
  ChartDetection detection;  // as detected on the refit
  struct Pattern {           // one per measured pattern, in measurement order
    PatternFrame frame;      // the frame its profile was sampled in on the refit
    double fit_shift_mm = 0; // where in that frame its fit centred it, along u
    std::shared_ptr<const IndexedArtwork> artwork;  // its plane's ideal (own bars and neighbours)
    Strip strip;
    ProfileSamplingOptions sampling;
    // Anchors (coarse, found, well modulated on the refit) follow the
    // chart's motion: their profile across the bars on the refit, (u mm,
    // level) in `frame`, is what each later frame's profile is matched with.
    bool anchor = false;
    std::vector<std::pair<double, double>> anchor_levels;
  };
  std::vector<Pattern> patterns;
  ReferenceResult reference;            // the refit's level steps
  std::vector<ElementResult> elements;  // the last frame's, one per pattern (carried when not fitted)
  ChartMotion motion;                   // from the refit to the last frame
  // Whether the refit resolved every element it found, per orientation. A
  // tracked frame that does, where the refit did not, has come into
  // better focus than the refit's detection reaches (finer elements may
  // show now): it is not usable, so that the chart is detected again.
  bool refit_beyond_finest_h = false, refit_beyond_finest_v = false;
};

struct ChartFramePlan {
  // Null: detect the chart and measure it from scratch (a refit).
  const ChartTrack* track = nullptr;
  // With a track: fit only the elements this accepts (given their last
  // result); the others keep it. Empty: fit every element.
  std::function<bool(const ElementResult&)> fit_element;
};

struct ChartFrameResult {
  ChartMeasurement measurement;
  std::optional<ChartTrack> track;  // set when the measurement is usable
  bool tracked = false;             // measured through the plan's track
};

// measure_chart with a plan: measure_chart(...) is
// measure_chart_frame(..., {}).measurement (which also makes the track).
ChartFrameResult measure_chart_frame(const LoadedImage& image, const ChartMeasureOptions& options,
                                     const ChartFramePlan& plan);

}  // namespace tactres
