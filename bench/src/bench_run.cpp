// Running the bench (docs/BENCH.md): every selected scene rendered to real
// image files, every capture decoded and measured single-threaded under
// every selected setting with the time taken, each orientation compared with
// the truth, and the rows summarised per setting. The suite itself is
// bench_suite.cpp; the CSV and text outputs are bench_output.cpp.
#include "tactres/bench/bench.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <fstream>
#include <map>
#include <stdexcept>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <OpenImageIO/imageio.h>

#include "tactres/camera/image_io.h"
#include "tactres/simulate/renderer.h"
#include "tactres/simulate/truth.h"
#include "tactres/targets/layout_json.h"
#include "tactres/util/atomic_file.h"
#include "tactres/util/json_fields.h"
#include "bench_stats.h"

namespace tactres {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }
using bench_stats::mean;
using bench_stats::median;
using bench_stats::percentile;
using bench_stats::thread_cpu_ms;

// --------------------------------------------------------------- rendering

struct Capture {
  fs::path file;
  int supersampling = 0;
  double render_ms = 0;
  std::string render_problem;  // non-empty: the render failed, nothing to measure
};

Capture render_capture(const BenchScene& b, int supersampling, const TargetLayout& layout, const CameraModel& camera,
                       const fs::path& dir, const std::string& stem) {
  Capture c;
  c.supersampling = supersampling;
  Scene s = b.scene;
  s.supersampling = supersampling;
  try {
    const auto t = Clock::now();
    const RenderResult r = render_scene(s, layout, camera);
    c.render_ms = ms_since(t);
    // Float TIFF without a sensor, 16-bit PNG with one: what `tactres
    // simulate` writes, so the decode time is that of real files.
    c.file = dir / (stem + (r.bits > 0 ? ".png" : ".tif"));
    write_image(c.file, r.image, r.bits);
  } catch (const std::invalid_argument& e) {
    c.render_problem = std::string("render failed: ") + e.what();
  }
  return c;
}

// The captures of one scene, by supersampling: the base render, and for
// sweep scenes one per supersampling value (the base value reuses the base
// render). Then the scene's truth file beside them.
std::map<int, Capture> render_captures(const BenchScene& b, const Truth& truth, bool any_supersampling_sweep,
                                       const TargetLayout& layout, const CameraModel& camera,
                                       const fs::path& captures_dir) {
  std::map<int, Capture> captures;
  captures[kBenchBaseSupersampling] =
      render_capture(b, kBenchBaseSupersampling, layout, camera, captures_dir, b.name);
  if (b.supersampling_sweep && any_supersampling_sweep)
    for (int ss : kBenchSupersampling)
      if (!captures.count(ss))
        captures[ss] = render_capture(b, ss, layout, camera, captures_dir, fmt::format("{}.ss{}", b.name, ss));
  // The truth does not depend on supersampling: one file per scene, named
  // after the base capture as `tactres simulate` would.
  const Capture& base_capture = captures.at(kBenchBaseSupersampling);
  write_file_atomically(
      captures_dir / (b.name + ".truth.json"),
      json_text(truth_to_json(truth, b.scene,
                              base_capture.file.empty() ? b.name : base_capture.file.filename().string())) +
          "\n");
  return captures;
}

// --------------------------------------------------------------- measuring

// Analysis must be timed single-threaded; the renderer may use every core.
// OpenCV's and OpenImageIO's pools are process-wide, so set and restore.
class SingleThreaded {
 public:
  SingleThreaded() : cv_threads_(cv::getNumThreads()) {
    OIIO::getattribute("threads", oiio_threads_);
    cv::setNumThreads(1);
    OIIO::attribute("threads", 1);
  }
  ~SingleThreaded() {
    cv::setNumThreads(cv_threads_);
    OIIO::attribute("threads", oiio_threads_);
  }
  SingleThreaded(const SingleThreaded&) = delete;
  SingleThreaded& operator=(const SingleThreaded&) = delete;

 private:
  int cv_threads_;
  int oiio_threads_ = 0;
};

// load_image over every measurement of the run, in ms: the decode floor.
struct DecodeTimes {
  std::vector<double> cpu_ms, wall_ms;
};

// What every row of one capture under one setting shares: the scene, the
// setting, and the render time.
BenchRow capture_row(const BenchScene& b, const BenchSetting& setting, const Capture& cap) {
  BenchRow base;
  base.scene = b.name;
  base.target = b.target;
  base.view = b.view;
  base.distance_mm = b.distance_mm;
  base.blur_sigma_px = b.blur_sigma_px;
  base.snr_db = b.snr_db;
  base.roll_deg = b.roll_deg;
  base.tilt_deg = b.tilt_deg;
  base.offset_mm = b.offset_mm;
  base.supersampling = cap.supersampling;
  base.setting = setting.name;
  base.sweep = setting.sweep;
  base.preset = to_string(setting.options.preset);
  base.bin_px = setting.options.sampling.bin_px;
  base.fit_psf_shape = setting.options.fit_psf_shape;
  base.pose_boundary_points = setting.options.pose_boundary_points;
  base.render_ms = cap.render_ms;
  return base;
}

// Decodes and measures one capture, timing both into `base`. A capture that
// cannot be measured is no error of the bench: its problem goes into `base`
// and there is no measurement.
std::optional<Measurement> measure_timed(const Capture& cap, const BenchSetting& setting, const TargetLayout& layout,
                                         const CameraModel& camera, BenchRow& base, DecodeTimes& decodes) {
  std::optional<Measurement> m;
  if (!cap.render_problem.empty()) {
    base.problem = cap.render_problem;
    return m;
  }
  try {
    auto t = Clock::now();
    double cpu = thread_cpu_ms();
    const LoadedImage img = load_image(cap.file);
    base.decode_cpu_ms = thread_cpu_ms() - cpu;
    base.decode_ms = ms_since(t);
    decodes.cpu_ms.push_back(base.decode_cpu_ms);
    decodes.wall_ms.push_back(base.decode_ms);
    t = Clock::now();
    cpu = thread_cpu_ms();
    m = measure_capture(img, layout, &camera, setting.options);
    base.analysis_cpu_ms = thread_cpu_ms() - cpu;
    base.analysis_ms = ms_since(t);
  } catch (const std::invalid_argument& e) {  // a measurement must not throw: record it
    base.problem = std::string("measure threw: ") + e.what();
  } catch (const UnusableInput& e) {
    base.problem = e.what();
  }
  return m;
}

// The measurement's stage times into the row's columns; whatever no column
// names (validation, a stage added later) is "other".
void fill_stage_times(BenchRow& row, const Measurement& m) {
  double staged = 0;
  for (const auto& [stage, seconds] : m.stage_seconds) {
    const double ms = 1000 * seconds;
    double* slot = stage == "locate_fiducials" ? &row.locate_fiducials_ms
                   : stage == "pose"           ? &row.pose_ms
                   : stage == "reference_patch" ? &row.reference_patch_ms
                   : stage == "profiles"       ? &row.profiles_ms
                   : stage == "fits"           ? &row.fits_ms
                   : stage == "decide"         ? &row.decide_ms
                                               : nullptr;  // a new stage: counted in "other"
    if (slot) {
      *slot += ms;
      staged += ms;
    }
  }
  row.other_ms = std::max(0.0, row.analysis_ms - staged);
}

void fill_limits(BenchRow& row, const Limit& truth, const Truth& t, BarOrientation o, const Limit* measured) {
  if (truth.any_resolved) {
    row.truth_group = truth.group;
    row.truth_element = truth.element;
    row.truth_lp_per_mm = truth.lp_per_mm;
    for (const TruthElement& e : t.elements)
      if (e.group == truth.group && e.element == truth.element && e.orientation == o) row.truth_px_per_bar = e.px_per_bar;
  }
  row.truth_interpolated_lp_per_mm = truth.interpolated_lp_per_mm;
  if (!measured) return;
  if (measured->any_resolved) {
    row.measured_group = measured->group;
    row.measured_element = measured->element;
    row.measured_lp_per_mm = measured->lp_per_mm;
  }
  row.measured_interpolated_lp_per_mm = measured->interpolated_lp_per_mm;
  row.uncertainty_lp_per_mm = measured->uncertainty_lp_per_mm;
  row.discrete_agree = measured->any_resolved == truth.any_resolved &&
                       (!truth.any_resolved || (measured->group == truth.group && measured->element == truth.element));
  if (row.truth_interpolated_lp_per_mm && row.measured_interpolated_lp_per_mm) {
    row.relative_error = *row.measured_interpolated_lp_per_mm / *row.truth_interpolated_lp_per_mm - 1;
    if (row.uncertainty_lp_per_mm)
      row.covered_2sigma = std::abs(*row.measured_interpolated_lp_per_mm - *row.truth_interpolated_lp_per_mm) <=
                           2 * *row.uncertainty_lp_per_mm;
  }
}

// One row per orientation, each against that orientation's truth.
void append_orientation_rows(const BenchRow& base, const Truth& truth, const std::optional<Measurement>& m,
                             std::vector<BenchRow>& rows) {
  for (BarOrientation o : {BarOrientation::horizontal_bars, BarOrientation::vertical_bars}) {
    BenchRow row = base;
    row.orientation = to_string(o);
    const Limit& t = o == BarOrientation::horizontal_bars ? truth.horizontal : truth.vertical;
    const Limit* ml =
        m && m->usable ? (o == BarOrientation::horizontal_bars ? &m->horizontal : &m->vertical) : nullptr;
    fill_limits(row, t, truth, o, ml);
    rows.push_back(std::move(row));
  }
}

struct SceneCounts {
  int measured = 0, usable = 0;
};

// Every setting that applies to the scene, on its capture, single-threaded.
// A supersampling setting applies only to the captures of the sweep.
SceneCounts measure_scene(const BenchScene& b, const std::map<int, Capture>& captures, const Truth& truth,
                          const std::vector<BenchSetting>& settings, const TargetLayout& layout,
                          const CameraModel& camera, DecodeTimes& decodes, std::vector<BenchRow>& rows) {
  SceneCounts counts;
  const SingleThreaded single;
  for (const BenchSetting& setting : settings) {
    if (setting.supersampling > 0 && !(b.supersampling_sweep && captures.count(setting.supersampling))) continue;
    const Capture& cap = captures.at(setting.supersampling > 0 ? setting.supersampling : kBenchBaseSupersampling);
    BenchRow base = capture_row(b, setting, cap);
    const std::optional<Measurement> m = measure_timed(cap, setting, layout, camera, base, decodes);
    ++counts.measured;
    if (m) {
      base.usable = m->usable;
      base.problem = m->problem;
      counts.usable += m->usable;
      fill_stage_times(base, *m);
    }
    append_orientation_rows(base, truth, m, rows);
  }
  return counts;
}

// ------------------------------------------------------------- the run

std::string machine_description() {
  std::string model = "unknown CPU";
  std::ifstream cpu("/proc/cpuinfo");
  for (std::string line; std::getline(cpu, line);)
    if (line.rfind("model name", 0) == 0) {
      model = line.substr(line.find(':') + 2);
      break;
    }
  std::string load;
  std::ifstream la("/proc/loadavg");
  std::getline(la, load);
  load = load.substr(0, load.find(' '));
  return fmt::format("{}, {} hardware threads, 1-min load average {} at start", model,
                     std::thread::hardware_concurrency(), load.empty() ? "unknown" : load);
}

// Creates the captures folder and returns it. The layout and camera go
// beside the captures, so that any capture can be re-measured with
// `tactres measure --layout DIR/layout.json --camera DIR/camera.cameramodel`.
fs::path prepare_out_dir(const fs::path& out_dir, const TargetLayout& layout, const CameraModel& camera) {
  const fs::path captures_dir = out_dir / "captures";
  std::error_code ec;
  fs::create_directories(captures_dir, ec);
  if (ec) throw std::runtime_error("cannot create " + captures_dir.string() + ": " + ec.message());
  write_layout_file(out_dir / "layout.json", layout);
  camera.save(out_dir / "camera.cameramodel");
  return captures_dir;
}

// The suite's scenes the options ask for: the named ones, else the (quick) suite.
std::vector<BenchScene> selected_scenes(const BenchOptions& options, const CameraModel& camera) {
  std::vector<BenchScene> scenes;
  for (BenchScene& s : bench_suite(camera)) {
    const bool wanted = options.scenes.empty()
                            ? (!options.quick || s.in_quick)
                            : std::find(options.scenes.begin(), options.scenes.end(), s.name) != options.scenes.end();
    if (wanted) scenes.push_back(std::move(s));
  }
  return scenes;
}

// The settings the options ask for: the named ones, else all of them.
std::vector<BenchSetting> selected_settings(const BenchOptions& options) {
  std::vector<BenchSetting> settings;
  for (BenchSetting& s : bench_settings())
    if (options.settings.empty() ||
        std::find(options.settings.begin(), options.settings.end(), s.name) != options.settings.end())
      settings.push_back(std::move(s));
  return settings;
}

}  // namespace

BenchResult run_bench(const BenchOptions& options, const std::function<void(const std::string&)>& progress) {
  options.validate();
  const auto t_start = Clock::now();
  BenchResult result;
  result.quick = options.quick;
  result.machine = machine_description();

  const TargetLayout layout = make_layout({});
  const CameraModel camera = options.camera_path ? CameraModel::load(*options.camera_path) : bench_default_camera();
  result.camera = options.camera_path ? options.camera_path->string()
                                      : "built-in example wide-angle camera (examples/cameras/wide_angle.cameramodel)";
  const fs::path captures_dir = prepare_out_dir(options.out_dir, layout, camera);

  const std::vector<BenchScene> scenes = selected_scenes(options, camera);
  const std::vector<BenchSetting> settings = selected_settings(options);
  const bool any_supersampling_sweep =
      std::any_of(settings.begin(), settings.end(), [](const BenchSetting& s) { return s.supersampling > 0; });

  DecodeTimes decodes;
  double render_ms_total = 0, measure_ms_total = 0;
  for (size_t si = 0; si < scenes.size(); ++si) {
    const BenchScene& b = scenes[si];
    const Truth truth = compute_truth(b.scene, layout, camera);
    const std::map<int, Capture> captures =
        render_captures(b, truth, any_supersampling_sweep, layout, camera, captures_dir);
    double scene_render_ms = 0;
    for (const auto& [ss, c] : captures) scene_render_ms += c.render_ms;
    render_ms_total += scene_render_ms;

    const auto t_measure = Clock::now();
    const SceneCounts counts = measure_scene(b, captures, truth, settings, layout, camera, decodes, result.rows);
    const double scene_measure_ms = ms_since(t_measure);
    measure_ms_total += scene_measure_ms;
    result.captures += counts.measured;
    if (progress)
      progress(fmt::format("[{}/{}] {}: rendered {} capture(s) in {:.1f} s, {}/{} measurements usable in {:.1f} s",
                           si + 1, scenes.size(), b.name, captures.size(), scene_render_ms / 1000, counts.usable,
                           counts.measured, scene_measure_ms / 1000));
  }
  result.scenes = int(scenes.size());
  result.summaries = summarize_bench(result.rows);
  result.decodes = int(decodes.cpu_ms.size());
  if (!decodes.cpu_ms.empty()) {
    result.decode_ms_median = median(decodes.cpu_ms);
    result.decode_ms_mean = mean(decodes.cpu_ms);
    result.decode_ms_p95 = percentile(decodes.cpu_ms, 0.95);
    result.decode_wall_ms_median = median(decodes.wall_ms);
  }
  if (options.live && options.scenes.empty() && options.settings.empty()) {
    LiveBenchOptions lo;
    lo.frames = options.quick ? 6 : 8;
    lo.chart = !options.quick;
    lo.out_dir = options.out_dir;
    result.live = run_live_bench(lo, progress);
  }
  result.render_seconds = render_ms_total / 1000;
  result.measure_seconds = measure_ms_total / 1000;
  result.wall_seconds = ms_since(t_start) / 1000;
  return result;
}

// ------------------------------------------------------------- statistics

std::vector<BenchSummary> summarize_bench(const std::vector<BenchRow>& rows) {
  std::vector<std::string> order;
  std::map<std::string, std::vector<const BenchRow*>> by_setting;
  for (const BenchRow& r : rows) {
    if (!by_setting.count(r.setting)) order.push_back(r.setting);
    by_setting[r.setting].push_back(&r);
  }
  std::vector<BenchSummary> out;
  for (const std::string& name : order) {
    const auto& rs = by_setting[name];
    BenchSummary s;
    s.setting = name;
    s.sweep = rs.front()->sweep;
    std::vector<double> ms, wall, stage[7], render, abs_err;
    int agree = 0, agree_n = 0, covered = 0, covered_n = 0;
    for (const BenchRow* r : rs) {
      // Capture-level numbers once per capture: on its first orientation.
      if (r->orientation == to_string(BarOrientation::horizontal_bars)) {
        ++s.captures;
        render.push_back(r->render_ms);
        if (r->usable) {
          ++s.usable_captures;
          ms.push_back(r->analysis_cpu_ms);
          wall.push_back(r->analysis_ms);
          const double v[7] = {r->locate_fiducials_ms, r->pose_ms, r->reference_patch_ms, r->profiles_ms,
                               r->fits_ms, r->decide_ms, r->other_ms};
          for (int k = 0; k < 7; ++k) stage[k].push_back(v[k]);
        }
      }
      if (r->usable) ++s.orientations;
      if (r->usable && r->truth_interpolated_lp_per_mm && !r->measured_interpolated_lp_per_mm) ++s.missing_limits;
      if (r->relative_error) abs_err.push_back(100 * std::abs(*r->relative_error));
      if (r->discrete_agree) {
        ++agree_n;
        agree += *r->discrete_agree;
      }
      if (r->covered_2sigma) {
        ++covered_n;
        covered += *r->covered_2sigma;
      }
    }
    s.errors = int(abs_err.size());
    s.ms_median = median(ms);
    s.ms_mean = mean(ms);
    s.wall_ms_median = median(wall);
    double* stage_out[7] = {&s.locate_fiducials_ms, &s.pose_ms, &s.reference_patch_ms, &s.profiles_ms,
                            &s.fits_ms, &s.decide_ms, &s.other_ms};
    for (int k = 0; k < 7; ++k) *stage_out[k] = median(stage[k]);
    s.render_ms_median = median(render);
    if (!abs_err.empty()) {
      s.median_abs_error_pct = percentile(abs_err, 0.5);
      s.p95_abs_error_pct = percentile(abs_err, 0.95);
    }
    if (s.errors + s.missing_limits > 0) s.interpolated_rate = double(s.errors) / (s.errors + s.missing_limits);
    if (agree_n) s.agreement_rate = double(agree) / agree_n;
    if (covered_n) s.coverage_rate = double(covered) / covered_n;
    out.push_back(s);
  }
  // Pareto front in (analysis time, median |error|), lower is better in both.
  // The supersampling sweep changes the simulator, not the analysis, so it
  // is no point on this front.
  auto candidate = [](const BenchSummary& s) {
    return s.sweep != "supersampling" && s.usable_captures > 0 && s.median_abs_error_pct.has_value();
  };
  for (BenchSummary& p : out) {
    if (!candidate(p)) continue;
    p.pareto = std::none_of(out.begin(), out.end(), [&](const BenchSummary& q) {
      return &q != &p && candidate(q) && q.ms_median <= p.ms_median &&
             *q.median_abs_error_pct <= *p.median_abs_error_pct &&
             (q.ms_median < p.ms_median || *q.median_abs_error_pct < *p.median_abs_error_pct);
    });
  }
  return out;
}

}  // namespace tactres
