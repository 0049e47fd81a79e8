#include "tactres/bench/bench.h"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <map>
#include <numbers>
#include <set>
#include <stdexcept>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <OpenImageIO/imageio.h>

#include "tactres/camera/image_io.h"
#include "tactres/util/csv.h"
#include "tactres/util/rng.h"
#include "tactres/simulate/renderer.h"
#include "tactres/simulate/effects/sensor_model.h"
#include "tactres/camera/target_view.h"
#include "tactres/simulate/truth.h"
#include "tactres/bench/bench_html.h"
#include "tactres/util/atomic_file.h"
#include "tactres/targets/layout_json.h"

namespace tactres {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }
// CPU time of the calling thread: the work done, whatever else the machine runs.
double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * double(ts.tv_sec) + 1e-6 * double(ts.tv_nsec);
}

// ---------------------------------------------------------------- the suite

// The suite's poses come from util/rng.h (splitmix64, uniform01): the same
// on every platform.

// Blur and distance pairs whose true limits run from group 1 to group 4 with
// the example wide-angle camera (560 px focal length: 21.5 px/mm at 26 mm).
// Distance sets the sampling, so the finer levels move the target closer.
struct Level {
  double distance_mm, sigma_px;
};
// The last level is sampling-limited on purpose: its true limit (group 4)
// falls where bars are narrower than the measurement's 1.5 px guard.
constexpr Level kLevels[] = {{34, 2.5}, {26, 2.5}, {26, 1.6}, {26, 1.0}, {20, 1.0}, {16, 1.0}, {13, 0.6}};
struct Condition {
  const char* target;
  const char* view;
};
constexpr Condition kConditions[] = {{"albedo", "direct"}, {"albedo", "through_gel"}, {"relief", "through_gel"}};
constexpr double kNoiseFree = 0;  // in kSnrDb: no sensor effect
constexpr double kSnrDb[] = {kNoiseFree, 40, 30, 20};
// Noise-free levels that are also rendered at every supersampling value.
constexpr int kSweepLevels[] = {1, 3, 4};
// The quick subset: (condition, level, noise) indices spanning every axis.
struct Pick {
  int condition, level, noise;
};
constexpr Pick kQuick[] = {{0, 0, 0}, {0, 2, 0}, {0, 3, 0}, {0, 4, 0}, {0, 6, 0}, {0, 3, 1},
                           {0, 2, 3}, {0, 5, 2}, {1, 3, 2}, {2, 4, 0}, {2, 2, 1}, {2, 1, 3}};

// Relief through the gel: a thin gel (contact smoothing 0.02 mm) and one
// light, as in examples/scenes/T1C1.json, linearised so the truth is analytic.
ContactEffect bench_contact() {
  ContactEffect c;
  c.sigma_mm = 0.02;
  c.depth_fraction = 0.8;
  return c;
}
ShadingEffect bench_shading() {
  ShadingEffect s;
  s.model = ShadingEffect::Model::lambert_linearised;
  s.albedo = 0.9;
  s.ambient = 0.0;
  s.lights = {Light{30.0, 55.0, 1.0}};
  return s;
}

// A 12-bit sensor whose SNR at `white` (the level of the flat ground) is
// `snr_db`, with the gain set so that white sits at 80 % of the range, as an
// auto-exposed camera would. Gain and photon count depend on each other
// through the quantisation noise, so iterate (converges in a few steps).
SensorOptions sensor_for_snr(double snr_db_target, double white, std::uint64_t seed) {
  SensorOptions o;
  o.bit_depth = 12;
  o.full_well_e = 40000;
  o.quantum_efficiency = 0.6;
  o.read_noise_e = 3;
  o.dark_signal_e = 0;
  o.seed = seed;
  for (int i = 0; i < 8; ++i) {
    o.photons_at_unity = photons_at_unity_for_snr_db(o, snr_db_target, white);
    o.gain_dn_per_e = 0.8 * o.max_dn() / (o.quantum_efficiency * o.photons_at_unity * white);
  }
  o.validate();
  return o;
}

std::string trim_number(double v) { return fmt::format("{:g}", v); }

// Whether the whole target (fiducial discs, reference patch, every element)
// lands inside the image with a margin: a scene whose target leaves the
// frame would measure the suite, not the analysis.
bool target_fits(const Scene& scene, const TargetLayout& layout, const CameraModel& camera) {
  constexpr double kMarginPx = 12;
  const TargetView view(camera, scene.rt_camera_from_target(layout));
  const double W = camera.imager_width(), H = camera.imager_height();
  auto inside = [&](Vec2 mm) {
    const auto px = view.project(mm);
    return px && px->x >= kMarginPx && px->y >= kMarginPx && px->x <= W - 1 - kMarginPx && px->y <= H - 1 - kMarginPx;
  };
  for (const Fiducial& f : layout.fiducials)
    for (int k = 0; k < 16; ++k) {
      const double a = 2 * std::numbers::pi * k / 16;
      if (!inside({f.center_mm.x + f.radius_mm * std::cos(a), f.center_mm.y + f.radius_mm * std::sin(a)}))
        return false;
    }
  std::vector<RectMm> rects{layout.reference_patch_mm};
  for (const ElementLayout& e : layout.elements) rects.push_back(e.extent_mm());
  for (const RectMm& r : rects)
    for (Vec2 c : {Vec2{r.x0, r.y0}, Vec2{r.x1, r.y0}, Vec2{r.x0, r.y1}, Vec2{r.x1, r.y1}})
      if (!inside(c)) return false;
  return true;
}

}  // namespace

std::vector<BenchScene> bench_suite() { return bench_suite(bench_default_camera()); }

std::vector<BenchScene> bench_suite(const CameraModel& camera) {
  const TargetLayout layout = make_layout({});
  std::vector<BenchScene> suite;
  std::uint64_t index = 0;
  for (int ci = 0; ci < int(std::size(kConditions)); ++ci)
    for (int li = 0; li < int(std::size(kLevels)); ++li)
      for (int ni = 0; ni < int(std::size(kSnrDb)); ++ni, ++index) {
        const Condition& c = kConditions[ci];
        const Level& l = kLevels[li];
        BenchScene b;
        b.target = c.target;
        b.view = c.view;
        b.distance_mm = l.distance_mm;
        b.blur_sigma_px = l.sigma_px;
        if (kSnrDb[ni] != kNoiseFree) b.snr_db = kSnrDb[ni];
        b.name = fmt::format("{}-{}-d{}-b{:.1f}-{}", c.target, b.view == "direct" ? "direct" : "gel", trim_number(l.distance_mm),
                             l.sigma_px, b.snr_db ? fmt::format("snr{}", trim_number(*b.snr_db)) : "clean");
        // Pose: any roll, a tilt up to 25 deg about any axis, and at the
        // longer distances an offset toward the strongly distorted image
        // margin. Close up the target only fits the frame near a multiple
        // of 90 deg of roll and nearly face-on, so a pose whose target
        // leaves the frame is shrunk toward that (deterministically) until
        // it fits.
        const double roll0 = -180 + 360 * uniform01(index, 0);
        const double tilt0 = 25 * uniform01(index, 1);
        b.tilt_axis_deg = std::round(360 * uniform01(index, 2));
        const std::array<double, 2> offset0 =
            l.distance_mm >= 26 ? std::array<double, 2>{-4 + 8 * uniform01(index, 3), -3 + 6 * uniform01(index, 4)}
                                : std::array<double, 2>{0, 0};
        const double square = 90 * std::round(roll0 / 90);
        for (const Pick& p : kQuick) b.in_quick |= p.condition == ci && p.level == li && p.noise == ni;
        for (int sl : kSweepLevels) b.supersampling_sweep |= sl == li && ni == 0;

        Scene& s = b.scene;
        s.design = "bench";
        s.description = "tactres bench scene " + b.name;
        s.target = b.target == "relief" ? TargetKind::relief : TargetKind::albedo;
        for (int attempt = 0; attempt < 40; ++attempt) {
          const double shrink = std::pow(0.8, attempt);
          b.roll_deg = std::round(square + (roll0 - square) * shrink);
          b.tilt_deg = std::round(tilt0 * shrink);
          b.offset_mm = {std::round(10 * offset0[0] * shrink) / 10, std::round(10 * offset0[1] * shrink) / 10};
          ViewPose v;
          v.view = b.view;
          v.distance_mm = b.distance_mm;
          v.roll_deg = b.roll_deg;
          v.tilt_deg = b.tilt_deg;
          v.tilt_axis_deg = b.tilt_axis_deg;
          v.offset_mm = b.offset_mm;
          s.view_pose = v;
          if (target_fits(s, layout, camera)) break;  // else: recorded as failures when measured
        }
        s.supersampling = kBenchBaseSupersampling;
        double white = s.ground_reflectance;
        if (s.target == TargetKind::relief) {
          const ShadingEffect sh = bench_shading();
          s.effects.emplace_back(bench_contact());
          s.effects.emplace_back(sh);
          // Radiance of the flat gel: albedo * sum w max(0, sin(elevation)).
          white = sh.ambient;
          for (const Light& li2 : sh.lights)
            white += sh.albedo * li2.weight * std::sin(li2.elevation_deg * std::numbers::pi / 180);
        }
        PsfOptions psf;
        psf.kind = PsfOptions::gaussian;
        psf.sigma_px = b.blur_sigma_px;
        s.effects.emplace_back(psf);
        if (b.snr_db) s.effects.emplace_back(sensor_for_snr(*b.snr_db, white, splitmix64(1000 + index)));
        suite.push_back(std::move(b));
      }
  return suite;
}

std::vector<BenchSetting> bench_settings() {
  std::vector<BenchSetting> out;
  for (Preset p : {Preset::fast, Preset::balanced, Preset::precise})
    out.push_back({to_string(p), "preset", MeasureOptions::for_preset(p), 0});
  const MeasureOptions balanced = MeasureOptions::for_preset(Preset::balanced);
  for (double bin : {0.125, 0.5, 1.0}) {
    BenchSetting s{fmt::format("balanced bin_px={}", trim_number(bin)), "bin_px", balanced, 0};
    s.options.sampling.bin_px = bin;
    out.push_back(s);
  }
  {
    BenchSetting s{"balanced fit_psf_shape=off", "fit_psf_shape", balanced, 0};
    s.options.fit_psf_shape = false;
    out.push_back(s);
  }
  for (int n : {8, 16, 96}) {
    BenchSetting s{fmt::format("balanced pose_boundary_points={}", n), "pose_boundary_points", balanced, 0};
    s.options.pose_boundary_points = n;
    out.push_back(s);
  }
  for (int ss : kBenchSupersampling)
    out.push_back({fmt::format("balanced supersampling={}", ss), "supersampling", balanced, ss});
  return out;
}

void BenchOptions::validate() const {
  if (out_dir.empty()) throw std::invalid_argument("say where the bench writes its files: --out DIR");
  std::set<std::string> known_scenes, known_settings;
  for (const BenchScene& s : bench_suite()) known_scenes.insert(s.name);
  for (const BenchSetting& s : bench_settings()) known_settings.insert(s.name);
  for (const std::string& s : scenes)
    if (!known_scenes.count(s))
      throw std::invalid_argument(fmt::format(
          "unknown bench scene '{}'; scenes are named like '{}' (`tactres bench --list` lists them)", s,
          *known_scenes.begin()));
  for (const std::string& s : settings)
    if (!known_settings.count(s))
      throw std::invalid_argument(fmt::format("unknown bench setting '{}'; settings are: {}", s,
                                              fmt::join(known_settings, ", ")));
}

CameraModel bench_default_camera() {
  // examples/cameras/wide_angle.cameramodel (see examples/cameras/README.md).
  CameraModel cam = CameraModel::from_lens(
      "LENSMODEL_OPENCV8", {560.0, 560.0, 641.3, 357.9, -0.3, 0.1, 0.0004, -0.0003, -0.005, 0.0, 0.0, 0.0}, 1280, 720);
  return cam;
}

namespace {

// --------------------------------------------------------------- measuring

// Percentile with linear interpolation between order statistics (the
// "type 7" definition of R and NumPy's default). `v` must not be empty.
double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  const double x = p * double(v.size() - 1);
  const size_t i = size_t(x);
  if (i + 1 >= v.size()) return v.back();
  return v[i] + (x - double(i)) * (v[i + 1] - v[i]);
}
double median(const std::vector<double>& v) { return v.empty() ? 0.0 : percentile(v, 0.5); }
double mean(const std::vector<double>& v) {
  double sum = 0;
  for (double x : v) sum += x;
  return v.empty() ? 0.0 : sum / double(v.size());
}


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

  const fs::path captures_dir = options.out_dir / "captures";
  std::error_code ec;
  fs::create_directories(captures_dir, ec);
  if (ec) throw std::runtime_error("cannot create " + captures_dir.string() + ": " + ec.message());
  // The layout and camera beside the captures, so that any capture can be
  // re-measured with `tactres measure --layout DIR/layout.json --camera DIR/camera.cameramodel`.
  write_layout_file(options.out_dir / "layout.json", layout);
  camera.save(options.out_dir / "camera.cameramodel");

  std::vector<BenchScene> scenes;
  for (BenchScene& s : bench_suite(camera)) {
    const bool wanted = options.scenes.empty()
                            ? (!options.quick || s.in_quick)
                            : std::find(options.scenes.begin(), options.scenes.end(), s.name) != options.scenes.end();
    if (wanted) scenes.push_back(std::move(s));
  }
  std::vector<BenchSetting> settings;
  for (BenchSetting& s : bench_settings())
    if (options.settings.empty() ||
        std::find(options.settings.begin(), options.settings.end(), s.name) != options.settings.end())
      settings.push_back(std::move(s));
  const bool any_supersampling_sweep =
      std::any_of(settings.begin(), settings.end(), [](const BenchSetting& s) { return s.supersampling > 0; });

  std::vector<double> decode_ms, decode_wall_ms;
  double render_ms_total = 0, measure_ms_total = 0;
  for (size_t si = 0; si < scenes.size(); ++si) {
    const BenchScene& b = scenes[si];
    const Truth truth = compute_truth(b.scene, layout, camera);

    // Captures: the base render, and for sweep scenes one per supersampling
    // value (the base value reuses the base render).
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
        truth_to_json(truth, b.scene, base_capture.file.empty() ? b.name : base_capture.file.filename().string())
                .dump(2) +
            "\n");
    double scene_render_ms = 0;
    for (const auto& [ss, c] : captures) scene_render_ms += c.render_ms;
    render_ms_total += scene_render_ms;

    const auto t_measure = Clock::now();
    int measured = 0, usable = 0;
    {
      const SingleThreaded single;
      for (const BenchSetting& setting : settings) {
        if (setting.supersampling > 0 && !(b.supersampling_sweep && captures.count(setting.supersampling))) continue;
        const Capture& cap = captures.at(setting.supersampling > 0 ? setting.supersampling : kBenchBaseSupersampling);
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

        std::optional<Measurement> m;
        if (!cap.render_problem.empty()) {
          base.problem = cap.render_problem;
        } else {
          try {
            auto t = Clock::now();
            double cpu = thread_cpu_ms();
            const LoadedImage img = load_image(cap.file);
            base.decode_cpu_ms = thread_cpu_ms() - cpu;
            base.decode_ms = ms_since(t);
            decode_ms.push_back(base.decode_cpu_ms);
            decode_wall_ms.push_back(base.decode_ms);
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
        }
        ++measured;
        if (m) {
          base.usable = m->usable;
          base.problem = m->problem;
          usable += m->usable;
          double staged = 0;
          for (const auto& [stage, seconds] : m->stage_seconds) {
            const double ms = 1000 * seconds;
            double* slot = stage == "locate_fiducials" ? &base.locate_fiducials_ms
                           : stage == "pose"           ? &base.pose_ms
                           : stage == "reference_patch" ? &base.reference_patch_ms
                           : stage == "profiles"       ? &base.profiles_ms
                           : stage == "fits"           ? &base.fits_ms
                           : stage == "decide"         ? &base.decide_ms
                                                       : nullptr;  // a new stage: counted in "other"
            if (slot) {
              *slot += ms;
              staged += ms;
            }
          }
          base.other_ms = std::max(0.0, base.analysis_ms - staged);
        }
        for (BarOrientation o : {BarOrientation::horizontal_bars, BarOrientation::vertical_bars}) {
          BenchRow row = base;
          row.orientation = to_string(o);
          const Limit& t = o == BarOrientation::horizontal_bars ? truth.horizontal : truth.vertical;
          const Limit* ml = m && m->usable ? (o == BarOrientation::horizontal_bars ? &m->horizontal : &m->vertical)
                                           : nullptr;
          fill_limits(row, t, truth, o, ml);
          result.rows.push_back(std::move(row));
        }
      }
    }
    const double scene_measure_ms = ms_since(t_measure);
    measure_ms_total += scene_measure_ms;
    result.captures += measured;
    if (progress)
      progress(fmt::format("[{}/{}] {}: rendered {} capture(s) in {:.1f} s, {}/{} measurements usable in {:.1f} s",
                           si + 1, scenes.size(), b.name, captures.size(), scene_render_ms / 1000, usable, measured,
                           scene_measure_ms / 1000));
  }
  result.scenes = int(scenes.size());
  result.summaries = summarize_bench(result.rows);
  result.decodes = int(decode_ms.size());
  if (!decode_ms.empty()) {
    result.decode_ms_median = median(decode_ms);
    result.decode_ms_mean = mean(decode_ms);
    result.decode_ms_p95 = percentile(decode_ms, 0.95);
    result.decode_wall_ms_median = median(decode_wall_ms);
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

// ------------------------------------------------------------------ output

namespace {

// Finite numbers only; anything else is an empty cell.
std::string num(double v, int decimals) { return std::isfinite(v) ? fmt::format("{:.{}f}", v, decimals) : ""; }
std::string num(const std::optional<double>& v, int decimals) { return v ? num(*v, decimals) : ""; }
std::string integer(const std::optional<int>& v) { return v ? std::to_string(*v) : ""; }
std::string flag(bool v) { return v ? "1" : "0"; }
std::string flag(const std::optional<bool>& v) { return v ? flag(*v) : ""; }

using Column = std::pair<const char*, std::function<std::string(const BenchRow&)>>;

const std::vector<Column>& columns() {
  static const std::vector<Column> cols = {
      {"scene", [](const BenchRow& r) { return r.scene; }},
      {"target", [](const BenchRow& r) { return r.target; }},
      {"view", [](const BenchRow& r) { return r.view; }},
      {"distance_mm", [](const BenchRow& r) { return num(r.distance_mm, 1); }},
      {"blur_sigma_px", [](const BenchRow& r) { return num(r.blur_sigma_px, 2); }},
      {"snr_db", [](const BenchRow& r) { return num(r.snr_db, 1); }},
      {"roll_deg", [](const BenchRow& r) { return num(r.roll_deg, 1); }},
      {"tilt_deg", [](const BenchRow& r) { return num(r.tilt_deg, 1); }},
      {"offset_x_mm", [](const BenchRow& r) { return num(r.offset_mm[0], 1); }},
      {"offset_y_mm", [](const BenchRow& r) { return num(r.offset_mm[1], 1); }},
      {"supersampling", [](const BenchRow& r) { return std::to_string(r.supersampling); }},
      {"setting", [](const BenchRow& r) { return r.setting; }},
      {"sweep", [](const BenchRow& r) { return r.sweep; }},
      {"preset", [](const BenchRow& r) { return r.preset; }},
      {"bin_px", [](const BenchRow& r) { return num(r.bin_px, 3); }},
      {"fit_psf_shape", [](const BenchRow& r) { return flag(r.fit_psf_shape); }},
      {"pose_boundary_points", [](const BenchRow& r) { return std::to_string(r.pose_boundary_points); }},
      {"orientation", [](const BenchRow& r) { return r.orientation; }},
      {"usable", [](const BenchRow& r) { return flag(r.usable); }},
      {"problem", [](const BenchRow& r) { return r.problem; }},
      {"render_ms", [](const BenchRow& r) { return num(r.render_ms, 3); }},
      {"decode_ms", [](const BenchRow& r) { return num(r.decode_ms, 3); }},
      {"decode_cpu_ms", [](const BenchRow& r) { return num(r.decode_cpu_ms, 3); }},
      {"analysis_ms", [](const BenchRow& r) { return num(r.analysis_ms, 3); }},
      {"analysis_cpu_ms", [](const BenchRow& r) { return num(r.analysis_cpu_ms, 3); }},
      {"locate_fiducials_ms", [](const BenchRow& r) { return num(r.locate_fiducials_ms, 3); }},
      {"pose_ms", [](const BenchRow& r) { return num(r.pose_ms, 3); }},
      {"reference_patch_ms", [](const BenchRow& r) { return num(r.reference_patch_ms, 3); }},
      {"profiles_ms", [](const BenchRow& r) { return num(r.profiles_ms, 3); }},
      {"fits_ms", [](const BenchRow& r) { return num(r.fits_ms, 3); }},
      {"decide_ms", [](const BenchRow& r) { return num(r.decide_ms, 3); }},
      {"other_ms", [](const BenchRow& r) { return num(r.other_ms, 3); }},
      {"truth_group", [](const BenchRow& r) { return integer(r.truth_group); }},
      {"truth_element", [](const BenchRow& r) { return integer(r.truth_element); }},
      {"truth_lp_per_mm", [](const BenchRow& r) { return num(r.truth_lp_per_mm, 4); }},
      {"truth_interpolated_lp_per_mm", [](const BenchRow& r) { return num(r.truth_interpolated_lp_per_mm, 4); }},
      {"truth_px_per_bar", [](const BenchRow& r) { return num(r.truth_px_per_bar, 3); }},
      {"measured_group", [](const BenchRow& r) { return integer(r.measured_group); }},
      {"measured_element", [](const BenchRow& r) { return integer(r.measured_element); }},
      {"measured_lp_per_mm", [](const BenchRow& r) { return num(r.measured_lp_per_mm, 4); }},
      {"measured_interpolated_lp_per_mm",
       [](const BenchRow& r) { return num(r.measured_interpolated_lp_per_mm, 4); }},
      {"uncertainty_lp_per_mm", [](const BenchRow& r) { return num(r.uncertainty_lp_per_mm, 4); }},
      {"relative_error", [](const BenchRow& r) { return num(r.relative_error, 6); }},
      {"discrete_agree", [](const BenchRow& r) { return flag(r.discrete_agree); }},
      {"covered_2sigma", [](const BenchRow& r) { return flag(r.covered_2sigma); }},
  };
  return cols;
}

}  // namespace

std::vector<std::string> bench_csv_columns() {
  std::vector<std::string> names;
  for (const Column& c : columns()) names.emplace_back(c.first);
  return names;
}

std::string bench_csv(const std::vector<BenchRow>& rows) {
  std::string out = fmt::format("{}\n", fmt::join(bench_csv_columns(), ","));
  for (const BenchRow& r : rows) {
    for (size_t i = 0; i < columns().size(); ++i) {
      if (i > 0) out += ',';
      out += csv_cell(columns()[i].second(r));
    }
    out += '\n';
  }
  return out;
}

std::string bench_summary_csv(const BenchResult& result) {
  std::string out =
      "setting,sweep,captures,usable_captures,orientations,errors,missing_limits,ms_median,ms_mean,wall_ms_median,"
      "locate_fiducials_ms,pose_ms,reference_patch_ms,profiles_ms,fits_ms,decide_ms,other_ms,render_ms_median,"
      "median_abs_error_pct,p95_abs_error_pct,interpolated_rate,agreement_rate,coverage_rate,pareto\n";
  for (const BenchSummary& s : result.summaries)
    out += fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n", csv_cell(s.setting),
                       s.sweep, s.captures, s.usable_captures, s.orientations, s.errors, s.missing_limits,
                       num(s.ms_median, 3), num(s.ms_mean, 3), num(s.wall_ms_median, 3), num(s.locate_fiducials_ms, 3), num(s.pose_ms, 3),
                       num(s.reference_patch_ms, 3), num(s.profiles_ms, 3), num(s.fits_ms, 3), num(s.decide_ms, 3),
                       num(s.other_ms, 3), num(s.render_ms_median, 3), num(s.median_abs_error_pct, 4),
                       num(s.p95_abs_error_pct, 4), num(s.interpolated_rate, 4), num(s.agreement_rate, 4), num(s.coverage_rate, 4),
                       flag(s.pareto));
  out += fmt::format("decode (floor),floor,{},,,,,{},{},{},,,,,,,,,,,,,0\n", result.decodes,
                     num(result.decode_ms_median, 3), num(result.decode_ms_mean, 3),
                     num(result.decode_wall_ms_median, 3));
  return out;
}

std::string bench_table_text(const BenchResult& r) {
  auto pct = [](const std::optional<double>& v, int w) {
    return v ? fmt::format("{:>{}.2f}", *v, w) : fmt::format("{:>{}}", "-", w);
  };
  auto rate = [](const std::optional<double>& v, int w) {
    return v ? fmt::format("{:>{}.0f}%", 100 * *v, w - 1) : fmt::format("{:>{}}", "-", w);
  };
  std::string out = fmt::format("tactres bench{}: {} scenes, {} measurements; {}\n", r.quick ? " --quick" : "", r.scenes,
                                r.captures, r.machine);
  out += fmt::format("{:<36} {:>9} {:>7} {:>8} {:>8} {:>6} {:>6} {:>6} {:>7} {:>5}\n", "setting", "ms/capt.", "(wall)",
                     "med|e|%", "p95|e|%", "interp", "agree", "cover", "usable", "front");
  for (const BenchSummary& s : r.summaries)
    out += fmt::format("{:<36} {:>9.1f} {:>7.1f} {} {} {} {} {} {:>7} {:>5}\n", s.setting, s.ms_median, s.wall_ms_median,
                       pct(s.median_abs_error_pct, 8), pct(s.p95_abs_error_pct, 8), rate(s.interpolated_rate, 6),
                       rate(s.agreement_rate, 6), rate(s.coverage_rate, 6),
                       fmt::format("{}/{}", s.usable_captures, s.captures), s.pareto ? "*" : "");
  out += fmt::format("{:<36} {:>9.1f} {:>7.1f}   (OpenImageIO load_image, median of {}; p95 {:.1f} ms)\n",
                     "decode (floor)", r.decode_ms_median, r.decode_wall_ms_median, r.decodes, r.decode_ms_p95);
  out += "ms/capt.: median thread CPU time of the analysis (usable captures); (wall): median wall clock\n";
  out += "\nmedian wall-clock ms per stage (usable captures):\n";
  out += fmt::format("{:<36} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8}\n", "setting", "fiducial", "pose", "patch",
                     "profiles", "fits", "decide", "other");
  for (const BenchSummary& s : r.summaries)
    if (s.sweep == "preset")
      out += fmt::format("{:<36} {:>8.1f} {:>8.1f} {:>8.1f} {:>8.1f} {:>8.1f} {:>8.1f} {:>8.1f}\n", s.setting,
                         s.locate_fiducials_ms, s.pose_ms, s.reference_patch_ms, s.profiles_ms, s.fits_ms,
                         s.decide_ms, s.other_ms);
  out += fmt::format("\nrender {:.0f} s (multi-threaded), measure + decode {:.0f} s (single-threaded), wall {:.0f} s\n",
                     r.render_seconds, r.measure_seconds, r.wall_seconds);
  return out;
}

void write_bench_outputs(const BenchResult& result, const fs::path& dir, const HtmlReportOptions& html) {
  // The page first: it is the one output that can fail for want of a file
  // (Chart.js), and then nothing is half written.
  const std::string page = render_bench_html(result, html);
  write_file_atomically(dir / "bench.csv", bench_csv(result.rows));
  write_file_atomically(dir / "bench_summary.csv", bench_summary_csv(result));
  write_file_atomically(dir / "bench.html", page);
}

}  // namespace tactres
