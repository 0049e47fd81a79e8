#pragma once
// Shared by the measure_chart_*_test.cpp suites: simulated photographs of
// the standard USAF-1951 chart (MIL-STD-150A arrangement,
// `make_mil_std_chart`), measured with no layout and no fiducials
// (`measure_chart`), and the checks against the simulator's analytic truth
// (docs/CHART.md).

#include <filesystem>
#include <optional>
#include <string>

#include "scene_fixtures.h"
#include "tactres/measure/chart_measure.h"
#include "tactres/targets/mil_std_chart.h"

namespace tactres::chart_e2e {

// Groups 0..5: three nested pairs, 22 x 17 mm.
const TargetLayout& chart(Polarity polarity = Polarity::dark_bars_on_light);

// The groups 4..7 chart, for views under a microscope.
const TargetLayout& fine_chart();

struct ChartScene {
  ViewPose view;
  double blur_sigma_px = 2.0;
  Polarity polarity = Polarity::dark_bars_on_light;
  std::optional<SensorOptions> sensor;
  const TargetLayout* layout = nullptr;  // default: chart(polarity)
  std::optional<PsfOptions> psf;         // default: Gaussian of blur_sigma_px
};

Scene scene_of(const ChartScene& c);

struct ChartRun {
  std::filesystem::path file;
  Truth truth;
  ChartMeasurement result;
};

// Renders the scene into `dir` as `name`.png (or .tif for float output),
// measures the file as `tactres measure --chart` would, and keeps the truth.
ChartRun render_and_measure(const ChartScene& c, const testing::TempDir& dir, const std::string& name,
                            const ChartDetectOptions& detect = {});

// The view centred on the chart at a distance giving `px_per_mm`.
ViewPose view_at(double px_per_mm);

// A view that puts chart point `p_mm` on the optical axis (direct view,
// roll only).
ViewPose view_on(const TargetLayout& L, Vec2 p_mm, double px_per_mm, double roll_deg);

// Centre of the pair (g, g+1) in the chart.
Vec2 pair_center(const TargetLayout& L, int g);

const TruthElement* truth_for(const Truth& t, int g, int e, BarOrientation o);

// The true limits among the elements the measurement could see: those in
// view with at least the sampling minimum (MeasureOptions::min_px_per_bar).
// Elements out of view are dropped, not counted as unresolved, so a view of
// a few groups has a true limit too.
Limits visible_truth_limits(const Truth& t, const Criterion& c);

// The acceptance checks of issue 8 for one capture. Unanchored results are
// relative (largest element found = G0E1); they are compared with the truth
// after the shift that the element matching finds, which must be the same
// for every element.
void check_against_truth(const ChartRun& run, const std::string& label, int min_visible = 6);

// The true limit of a run is in `group` for both orientations (so that a
// case claims what it covers).
void check_true_limit_group(const ChartRun& run, int group);

}  // namespace tactres::chart_e2e
