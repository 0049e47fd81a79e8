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
// - Elements of which only one pattern was found (ChartDetection::partial)
//   are reported on both orientations with a status, not a guess:
//   out_of_view when the missing pattern lies outside the image, fit_failed
//   when it lies inside but was not found; never measured, never resolved,
//   left out of the limits. Elements partly out of the image are
//   out_of_view; m(f) is m(f) whether or not the chart is anchored.
// - Grading and the limits are layout mode's own code (element_grading.h).

#include "tactres/locate/chart_detect.h"
#include "tactres/camera/image_io.h"
#include "tactres/measure/measure.h"

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

}  // namespace tactres
