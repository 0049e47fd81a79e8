#pragma once
// Synthetic scenes with known truth for the end-to-end suites: the default
// target, an example camera, a pose in view terms, and a list of effects.
// Rendering goes through the real renderer and the real image files.

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "tactres/camera/camera_model.h"
#include "tactres/camera/image_io.h"
#include "tactres/measure/measure.h"
#include "tactres/simulate/renderer.h"
#include "tactres/simulate/scene.h"
#include "tactres/simulate/truth.h"
#include "tactres/targets/layout.h"

namespace tactres::testing {

inline std::filesystem::path source_dir() { return TACTRES_SOURCE_DIR; }

inline const TargetLayout& default_layout() {
  static const TargetLayout layout = make_layout({});
  return layout;
}

inline const CameraModel& wide_angle_camera() {
  static const CameraModel cam = CameraModel::load(source_dir() / "examples/cameras/wide_angle.cameramodel");
  return cam;
}

inline const CameraModel& pinhole_camera() {
  static const CameraModel cam = CameraModel::load(source_dir() / "examples/cameras/pinhole.cameramodel");
  return cam;
}

// A fresh folder under the system temp dir, removed at scope exit.
struct TempDir {
  std::filesystem::path path;
  explicit TempDir(const std::string& tag) {
    path = std::filesystem::temp_directory_path() /
           ("tactres-" + tag + "-" + std::to_string(::getpid()) + "-" + std::to_string(counter()++));
    std::filesystem::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  static int& counter() {
    static int n = 0;
    return n;
  }
};

inline Scene albedo_scene(ViewPose view, double blur_sigma_px, int supersampling = 3) {
  Scene s;
  s.design = "test";
  s.target = TargetKind::albedo;
  s.view_pose = view;
  s.supersampling = supersampling;
  if (blur_sigma_px > 0) {
    PsfOptions psf;
    psf.kind = PsfOptions::gaussian;
    psf.sigma_px = blur_sigma_px;
    s.effects.emplace_back(psf);
  }
  return s;
}

inline SensorOptions sensor_40db(std::uint64_t seed) {
  SensorOptions o;
  o.bit_depth = 12;
  o.full_well_e = 40000;
  o.photons_at_unity = 50000;  // ~85% of the well at 1.0: SNR ~ 43 dB at the ground level
  o.quantum_efficiency = 0.6;
  o.read_noise_e = 3;
  o.dark_signal_e = 0;
  o.seed = seed;
  return o;
}

struct Rendered {
  std::filesystem::path file;
  Truth truth;
};

// Renders `scene` to `dir/name` (float TIFF without a sensor, 16-bit PNG with one).
inline Rendered render_to_file(const Scene& scene, const CameraModel& camera, const std::filesystem::path& dir,
                               const std::string& name) {
  const RenderResult r = render_scene(scene, default_layout(), camera);
  const std::filesystem::path file = dir / (name + (r.bits > 0 ? ".png" : ".tif"));
  write_image(file, r.image, r.bits);
  return {file, compute_truth(scene, default_layout(), camera)};
}

inline Measurement measure_file(const std::filesystem::path& file, const CameraModel* camera,
                                Preset preset = Preset::balanced) {
  const LoadedImage img = load_image(file);
  return measure_capture(img, default_layout(), camera, MeasureOptions::for_preset(preset));
}

// The discrete limit agrees with the truth, or the true crossing lies inside
// the reported 2-sigma band around the measured limit, where either
// neighbouring element is a fair answer (issue #4's acceptance rule).
inline bool discrete_limit_agrees(const Limit& measured, const Limit& truth) {
  if (measured.any_resolved != truth.any_resolved) return false;
  if (!measured.any_resolved) return true;
  if (measured.group == truth.group && measured.element == truth.element) return true;
  if (!truth.interpolated_lp_per_mm || !measured.interpolated_lp_per_mm) return false;
  const double band = 2 * measured.uncertainty_lp_per_mm.value_or(0);
  const double next_lp_per_mm = std::exp2(measured.group + measured.element / 6.0);
  return std::abs(*truth.interpolated_lp_per_mm - measured.lp_per_mm) <= band ||
         std::abs(*truth.interpolated_lp_per_mm - next_lp_per_mm) <= band ||
         std::abs(*truth.interpolated_lp_per_mm - *measured.interpolated_lp_per_mm) <= band;
}

inline const TruthElement* truth_of(const Truth& t, const ElementResult& e) {
  for (const TruthElement& te : t.elements)
    if (te.group == e.group && te.element == e.element && te.orientation == e.orientation) return &te;
  return nullptr;
}

}  // namespace tactres::testing
