// A render case as a JSON file, for running the reference renderer by hand
// (reference_render) and for the CLI smoke test. Example:
//
// {
//   "layout": "target/layout.json",
//   "camera": {"pinhole": {"size_px": [1280, 720], "fx_px": 560, "fy_px": 560, "cx_px": 639.5, "cy_px": 359.5}},
//   "pose": {"distance_mm": 26, "roll_deg": 30, "tilt_deg": 0, "mirrored": false, "shift_mm": [0, 0]},
//   "scene": {"mode": "albedo", "sigma_mm": 0.11, "ink_albedo": 0.05, "ground_albedo": 0.85,
//             "light_bars_on_dark": false, "snr_db": 40, "seed": 1},
//   "output": {"image": "capture.png", "format": "png16", "truth": "capture.png.truth.json"}
// }
//
// "camera" may instead be a path to a .cameramodel. Relief scenes take
// "relief_mm", "light_azimuth_deg", "level" and "gain_per_slope". Paths are
// relative to the case file's folder. Unknown keys are refused.
#include <filesystem>
#include <fstream>
#include <set>
#include <stdexcept>

#include "reference_renderer.h"

namespace reference {
namespace {

namespace fs = std::filesystem;

void check_keys(const nlohmann::json& j, const std::set<std::string>& allowed, const std::string& where) {
  if (!j.is_object()) throw std::runtime_error("case: " + where + " must be an object");
  for (const auto& [key, value] : j.items())
    if (!allowed.count(key)) throw std::runtime_error("case: unknown key " + where + "." + key);
}

std::string resolve(const fs::path& base, const std::string& p) {
  return fs::path(p).is_absolute() ? p : (base / p).lexically_normal().string();
}

void read_camera(const nlohmann::json& j, const fs::path& base, RenderCase& c) {
  if (j.is_string()) {
    c.camera_path = resolve(base, j.get<std::string>());
    return;
  }
  check_keys(j, {"pinhole"}, "camera");
  const auto& p = j.at("pinhole");
  check_keys(p, {"size_px", "fx_px", "fy_px", "cx_px", "cy_px"}, "camera.pinhole");
  c.pinhole_size_px = {p.at("size_px").at(0).get<int>(), p.at("size_px").at(1).get<int>()};
  c.pinhole_fxfycxcy = {p.at("fx_px").get<double>(), p.at("fy_px").get<double>(), p.at("cx_px").get<double>(),
                        p.at("cy_px").get<double>()};
}

Pose read_pose(const nlohmann::json& j) {
  check_keys(j, {"distance_mm", "roll_deg", "tilt_deg", "mirrored", "shift_mm"}, "pose");
  Pose p;
  p.distance_mm = j.value("distance_mm", p.distance_mm);
  p.roll_deg = j.value("roll_deg", p.roll_deg);
  p.tilt_deg = j.value("tilt_deg", p.tilt_deg);
  p.mirrored = j.value("mirrored", p.mirrored);
  if (j.contains("shift_mm")) p.shift_mm = {j["shift_mm"].at(0).get<double>(), j["shift_mm"].at(1).get<double>()};
  return p;
}

Scene read_scene(const nlohmann::json& j) {
  check_keys(j,
             {"mode", "sigma_mm", "ink_albedo", "ground_albedo", "light_bars_on_dark", "relief_mm",
              "light_azimuth_deg", "level", "gain_per_slope", "snr_db", "seed"},
             "scene");
  Scene s;
  s.mode = j.value("mode", s.mode);
  s.sigma_mm = j.at("sigma_mm").get<double>();
  s.ink_albedo = j.value("ink_albedo", s.ink_albedo);
  s.ground_albedo = j.value("ground_albedo", s.ground_albedo);
  s.light_bars_on_dark = j.value("light_bars_on_dark", s.light_bars_on_dark);
  s.relief_mm = j.value("relief_mm", s.relief_mm);
  s.light_azimuth_deg = j.value("light_azimuth_deg", s.light_azimuth_deg);
  s.level = j.value("level", s.level);
  s.gain_per_slope = j.value("gain_per_slope", s.gain_per_slope);
  s.snr_db = j.value("snr_db", s.snr_db);
  s.seed = j.value("seed", s.seed);
  if (!(s.sigma_mm > 0)) throw std::runtime_error("case: scene.sigma_mm must be > 0");
  return s;
}

}  // namespace

RenderCase read_case(const std::string& case_path) {
  std::ifstream in(case_path);
  if (!in) throw std::runtime_error("case: cannot open " + case_path);
  const nlohmann::json j = nlohmann::json::parse(in);
  check_keys(j, {"layout", "camera", "pose", "scene", "output"}, "case");
  const fs::path base = fs::path(case_path).parent_path();
  RenderCase c;
  c.layout_path = resolve(base, j.at("layout").get<std::string>());
  if (j.contains("camera")) read_camera(j["camera"], base, c);
  if (j.contains("pose")) c.pose = read_pose(j["pose"]);
  c.scene = read_scene(j.at("scene"));
  const auto& out = j.at("output");
  check_keys(out, {"image", "format", "truth"}, "output");
  c.image_path = resolve(base, out.at("image").get<std::string>());
  c.format = out.value("format", "");
  c.truth_path = out.contains("truth") ? resolve(base, out["truth"].get<std::string>()) : "";
  return c;
}

Truth run_case(const RenderCase& c) {
  const Layout layout = read_layout(c.layout_path);
  const Camera camera = c.camera_path.empty()
                            ? Camera::pinhole(c.pinhole_size_px[0], c.pinhole_size_px[1], c.pinhole_fxfycxcy[0],
                                              c.pinhole_fxfycxcy[1], c.pinhole_fxfycxcy[2], c.pinhole_fxfycxcy[3])
                            : Camera::from_file(c.camera_path);
  Image image = render_image(layout, camera, c.pose, c.scene);
  add_gaussian_noise(image, noise_sigma(layout, c.scene), c.scene.seed);
  write_image(c.image_path, image, c.format);
  const Truth truth = make_truth(layout, camera, c.pose, c.scene.sigma_mm);
  const std::string truth_path = c.truth_path.empty() ? c.image_path + ".truth.json" : c.truth_path;
  std::ofstream out(truth_path);
  out << truth_json(truth, c.pose, c.scene, camera, layout).dump(2) << "\n";
  if (!out) throw std::runtime_error("case: cannot write " + truth_path);
  return truth;
}

}  // namespace reference
