#pragma once
// `tactres bench`: what accuracy costs in time (docs/BENCH.md).
//
// A fixed, seeded suite of scenes with known truth is rendered through the
// real renderer to real image files, then every capture is measured with
// every precision preset and with a sweep of the settings that matter. For
// each setting the bench reports the single-threaded analysis time per
// capture by stage, the error of the interpolated limit against the truth,
// how often the discrete limit agrees, how often the reported uncertainty
// covers the truth at 2 sigma, and the OpenImageIO decode time of the same
// captures: the floor that no analysis can beat.

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "tactres/bench/bench_live.h"
#include "tactres/camera/camera_model.h"
#include "tactres/measure/measure.h"
#include "tactres/simulate/effects/sensor_model.h"
#include "tactres/simulate/scene.h"
#include "tactres/reports/report_html.h"

namespace tactres {

// One scene of the suite. The descriptive fields repeat what `scene` holds,
// in the words the CSV uses.
struct BenchScene {
  std::string name;              // unique and file-name safe, e.g. "albedo-direct-d26-b1.0-snr40"
  std::string target;            // albedo | relief
  std::string view;              // direct | through_gel
  double distance_mm = 26;
  double blur_sigma_px = 1;      // Gaussian PSF
  std::optional<double> snr_db;  // EMVA 1288 SNR at the white level; absent: noise-free (no sensor effect)
  double roll_deg = 0, tilt_deg = 0, tilt_axis_deg = 0;
  std::array<double, 2> offset_mm{0, 0};
  bool in_quick = false;                 // part of `--quick`
  bool supersampling_sweep = false;      // also rendered at every kBenchSupersampling value
  Scene scene;                           // rendered at scene.supersampling (kBenchBaseSupersampling)
};

// The renderer's supersampling for every capture, and the values of the
// simulator sweep (the base value is one of them: that capture is reused).
inline constexpr int kBenchBaseSupersampling = 3;
inline constexpr int kBenchSupersampling[] = {1, 2, 3, 4};

// The whole suite (quick scenes flagged). Deterministic: poses and noise
// seeds come from a fixed seed, drawn with integer arithmetic only, so every
// platform builds the same scenes. A drawn pose that would put part of the
// target outside `camera`'s image is shrunk toward face-on until it fits.
std::vector<BenchScene> bench_suite(const CameraModel& camera);
std::vector<BenchScene> bench_suite();  // with bench_default_camera()

// A 12-bit sensor whose SNR at `white` (the level of the flat ground) is
// `snr_db`, with white at 80 % of the range, as an auto-exposed camera
// would put it.
SensorOptions bench_sensor_for_snr(double snr_db, double white, std::uint64_t seed);

// A way to measure: a preset, or the balanced preset with one setting changed.
struct BenchSetting {
  std::string name;    // "fast", "balanced bin_px=0.5", "balanced supersampling=1", ...
  std::string sweep;   // preset | bin_px | fit_psf_shape | pose_boundary_points | supersampling
  MeasureOptions options;
  int supersampling = 0;  // sweep "supersampling": the capture rendered at this value; else 0
};

// Every setting, presets first.
std::vector<BenchSetting> bench_settings();

struct BenchOptions {
  bool quick = false;
  std::filesystem::path out_dir;  // captures, truth files, layout, camera model, CSV, HTML
  // Default: the example wide-angle camera (examples/cameras/wide_angle.cameramodel),
  // built in so that the bench needs no source tree. Another model must be
  // 1280 x 720-ish and sized like it, or scenes fall out of view (recorded
  // as failures, not errors).
  std::optional<std::filesystem::path> camera_path;
  std::vector<std::string> scenes;    // only these scene names; empty: the (quick) suite
  std::vector<std::string> settings;  // only these setting names; empty: every setting
  // Also the live-mode figures (bench_live.h): layout mode in --quick, and
  // the chart sequence too in a full run. Not with --scene or --setting.
  bool live = true;

  // Throws std::invalid_argument naming an unknown scene or setting.
  void validate() const;
};

// One capture measured with one setting, for one orientation.
struct BenchRow {
  std::string scene, target, view;
  double distance_mm = 0, blur_sigma_px = 0;
  std::optional<double> snr_db;
  double roll_deg = 0, tilt_deg = 0;
  std::array<double, 2> offset_mm{0, 0};
  int supersampling = 0;
  std::string setting, sweep, preset;
  double bin_px = 0;
  bool fit_psf_shape = true;
  int pose_boundary_points = 0;
  std::string orientation;  // horizontal_bars | vertical_bars
  bool usable = false;
  std::string problem;
  // Times in milliseconds. render: the simulator (multi-threaded, not
  // analysis); decode: load_image; analysis: measure_capture, single-threaded,
  // split by stage (wall clock, as Measurement::stage_seconds gives them),
  // "other" being the rest (validation, saturation check). The *_cpu_ms
  // times are the thread's CPU time: on a shared, loaded machine they are
  // what the same work takes on an idle core, where wall time is not.
  double render_ms = 0, decode_ms = 0, decode_cpu_ms = 0, analysis_ms = 0, analysis_cpu_ms = 0;
  double locate_fiducials_ms = 0, pose_ms = 0, reference_patch_ms = 0, profiles_ms = 0, fits_ms = 0,
         decide_ms = 0, other_ms = 0;
  // Truth and measurement of this orientation's limit.
  std::optional<int> truth_group, truth_element;
  std::optional<double> truth_lp_per_mm, truth_interpolated_lp_per_mm, truth_px_per_bar;
  std::optional<int> measured_group, measured_element;
  std::optional<double> measured_lp_per_mm, measured_interpolated_lp_per_mm, uncertainty_lp_per_mm;
  std::optional<double> relative_error;  // measured / truth - 1 of the interpolated limits
  std::optional<bool> discrete_agree;    // usable captures only
  std::optional<bool> covered_2sigma;    // |measured - truth| <= 2 uncertainty
};

// Per setting, over its captures (time) and their orientations (accuracy).
struct BenchSummary {
  std::string setting, sweep;
  int captures = 0, usable_captures = 0;
  int orientations = 0;     // of usable captures
  int errors = 0;           // orientations with both interpolated limits: the error sample
  int missing_limits = 0;   // of usable captures: the truth has an interpolated limit, the measurement none
  // Analysis time of usable captures, ms: thread CPU time (median, mean),
  // and wall clock (median, and the median of each stage).
  double ms_median = 0, ms_mean = 0, wall_ms_median = 0;
  double locate_fiducials_ms = 0, pose_ms = 0, reference_patch_ms = 0, profiles_ms = 0, fits_ms = 0,
         decide_ms = 0, other_ms = 0;
  double render_ms_median = 0;
  std::optional<double> median_abs_error_pct, p95_abs_error_pct;
  // Of the orientations of usable captures with a true interpolated limit,
  // the share for which the measurement reports one too (the rest are
  // missing_limits), in [0, 1].
  std::optional<double> interpolated_rate;
  std::optional<double> agreement_rate, coverage_rate;  // in [0, 1]
  bool pareto = false;  // on the time / median-error front (supersampling excluded: not an analysis setting)
};

struct BenchResult {
  bool quick = false;
  std::string machine;       // CPU model, cores, load average at start
  std::string camera;        // the camera model used
  int scenes = 0, captures = 0;
  std::vector<BenchRow> rows;
  std::vector<BenchSummary> summaries;
  // load_image over every measurement: thread CPU time, and wall clock.
  double decode_ms_median = 0, decode_ms_mean = 0, decode_ms_p95 = 0, decode_wall_ms_median = 0;
  int decodes = 0;
  double render_seconds = 0, measure_seconds = 0, wall_seconds = 0;
  std::vector<LiveBenchRow> live;  // empty when not run
};

// The built-in example wide-angle camera (same intrinsics as
// examples/cameras/wide_angle.cameramodel; a test keeps them equal).
CameraModel bench_default_camera();

// Renders, measures and summarises. `progress` gets one line per scene.
// Failures of a capture (no target found, a fit that throws) are rows with
// usable = false and the problem; only bad options and I/O errors throw.
BenchResult run_bench(const BenchOptions& options,
                      const std::function<void(const std::string&)>& progress = {});

std::vector<BenchSummary> summarize_bench(const std::vector<BenchRow>& rows);

// CSV of every row; the columns are documented in docs/BENCH.md. Absent
// values are empty cells, never NaN.
std::vector<std::string> bench_csv_columns();
std::string bench_csv(const std::vector<BenchRow>& rows);
// One row per setting, and a last row "decode (floor)".
std::string bench_summary_csv(const BenchResult& result);

// The short text table for stdout.
std::string bench_table_text(const BenchResult& result);

// Writes bench.csv, bench_summary.csv and bench.html (bench_html.h) into
// `dir`, atomically, and live.csv when the live figures were run.
void write_bench_outputs(const BenchResult& result, const std::filesystem::path& dir,
                         const HtmlReportOptions& html = {});

}  // namespace tactres
