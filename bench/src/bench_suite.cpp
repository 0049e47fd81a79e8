// The bench suite (docs/BENCH.md): the fixed, seeded scenes with known
// truth, the settings they are measured with, the check of a run's options
// against both, and the built-in camera. Running them is bench_run.cpp.
#include "tactres/bench/bench.h"

#include <cmath>
#include <cstdint>
#include <numbers>
#include <set>
#include <stdexcept>

#include <fmt/format.h>

#include "tactres/camera/target_view.h"
#include "tactres/simulate/effects/sensor_model.h"
#include "tactres/util/rng.h"

namespace tactres {
namespace {

// The suite's poses come from util/rng.h (splitmix64, uniform01): the same
// on every platform.

// Blur and distance pairs whose true limits run from group 1 to group 4 with
// the example wide-angle camera (560 px focal length: 21.5 px/mm at 26 mm).
// Distance sets the sampling, so the finer levels move the target closer.
struct Level {
  double distance_mm, sigma_px;
};
// The last level is sampling-limited on purpose: its true limit (group 4)
// falls where bars are narrower than the measurement's 1.25 px guard.
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
// light, as in tests/data/scenes/T1C1.json, linearised so the truth is analytic.
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

// A 12-bit sensor whose SNR at `white` (the level of the flat ground) is
// `snr_db`, with the gain set so that white sits at 80 % of the range, as an
// auto-exposed camera would. Gain and photon count depend on each other
// through the quantisation noise, so iterate (converges in a few steps).
SensorOptions bench_sensor_for_snr(double snr_db_target, double white, std::uint64_t seed) {
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
        if (b.snr_db) s.effects.emplace_back(bench_sensor_for_snr(*b.snr_db, white, splitmix64(1000 + index)));
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

}  // namespace tactres
