// Cases, runs of the real `tactres` binary, and the comparison with the
// reference renderer's own truth.
#include "e2e_support.h"

#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <mutex>
#include <random>
#include <sstream>
#include <stdexcept>

namespace reference::e2e {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

MeasuredLimit limit_from(const nlohmann::json& limits, const std::string& orientation) {
  MeasuredLimit L;
  if (!limits.is_object() || !limits.contains(orientation)) return L;
  const auto& j = limits[orientation];
  if (j.contains("interpolated_lp_per_mm") && j["interpolated_lp_per_mm"].is_number())
    L.interpolated_lp_per_mm = j["interpolated_lp_per_mm"].get<double>();
  if (j.contains("uncertainty_lp_per_mm") && j["uncertainty_lp_per_mm"].is_number())
    L.uncertainty_lp_per_mm = j["uncertainty_lp_per_mm"].get<double>();
  L.resolved_any = j.value("resolved_any", false);
  return L;
}

void compare_elements(const nlohmann::json& elements, CaseResult& r) {
  for (const auto& e : elements) {
    const std::string orientation = e.at("orientation").get<std::string>();
    const int group = e.at("group").get<int>(), element = e.at("element").get<int>();
    const TruthElement* t = r.truth.find(group, element, orientation);
    if (!t) throw std::runtime_error("measurement lists an element the layout does not have");
    const std::string status = e.value("status", "");
    char tag[160];
    std::snprintf(tag, sizeof tag, "G%dE%d%s", group, element, orientation == "horizontal_bars" ? "H" : "V");
    char text[320];
    if (e.value("resolved", false) && t->m < r.truth.threshold) {
      std::snprintf(text, sizeof text, "%s (m %.4f, m_true %.4f)", tag, e.value("m", 0.0), t->m);
      r.falsely_resolved.emplace_back(text);
    }
    if (t->px_per_bar < 3 || !t->in_view) continue;
    if (status != "ok") {
      std::snprintf(text, sizeof text, "%s %s at %.2f px/bar", tag, status.c_str(), t->px_per_bar);
      r.notes.emplace_back(text);
      continue;
    }
    r.max_abs_dm = std::max(r.max_abs_dm, std::abs(e.at("m").get<double>() - t->m));
    ++r.elements_compared;
  }
}

struct Cache {
  std::mutex mutex;
  std::map<std::string, CaseResult> results;
  std::unique_ptr<TempDir> dir;
};

Cache& cache() {
  static Cache c;
  return c;
}

}  // namespace

std::string tactres_binary() {
  const char* b = std::getenv("TACTRES_REFERENCE_TACTRES");
  return b && *b ? std::string(b) : std::string(TACTRES_BINARY);
}

int run_shell(const std::string& cmd) {
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

double sigma_for_limit_between(int group, int element) {
  const double f_lp_per_mm = std::pow(2.0, group + (element - 1) / 6.0 + 1.0 / 12.0);
  return std::sqrt(std::log(10.0) / (2 * M_PI * M_PI)) / f_lp_per_mm;
}

TempDir::TempDir(const std::string& tag) {
  std::random_device rd;
  const char* keep = std::getenv("TACTRES_REFERENCE_KEEP");
  const fs::path root = keep && *keep ? fs::path(keep) : fs::temp_directory_path();
  path = root / ("tactres-reference-" + tag + "-" + std::to_string(::getpid()) + "-" + std::to_string(rd() % 100000));
  fs::create_directories(path);
}

TempDir::~TempDir() {
  const char* keep = std::getenv("TACTRES_REFERENCE_KEEP");
  if (keep && *keep) return;
  std::error_code ec;
  fs::remove_all(path, ec);
}

const fs::path& default_layout_path() {
  static TempDir dir("layout");
  static const fs::path layout = [] {
    const std::string cmd = tactres_binary() + " generate --out " + (dir.path / "target").string() +
                            " > /dev/null 2>&1";
    if (run_shell(cmd) != 0) throw std::runtime_error("tactres generate failed: " + cmd);
    return dir.path / "target" / "layout.json";
  }();
  return layout;
}

const Layout& default_layout() {
  static const Layout layout = read_layout(default_layout_path().string());
  return layout;
}

Camera camera_named(const std::string& name) {
  if (name == "pinhole720") return Camera::pinhole(1280, 720, 560, 560, 639.5, 359.5);
  if (name == "pinhole5mp") return Camera::pinhole(2448, 2048, 2100, 2100, 1223.5, 1023.5);
  if (name == "wide_angle")
    return Camera::from_file(std::string(TACTRES_SOURCE_DIR) + "/examples/cameras/wide_angle.cameramodel");
  throw std::invalid_argument("no camera named " + name);
}

std::vector<CaseSpec> issue_cases() {
  // 1280x720 at 26 mm: 21.5 px/mm on the axis. Two blurs: the limit at 3.0
  // lp/mm (3.6 px per bar), or "sharp" at 3.78 lp/mm (2.85 px per bar).
  Scene albedo;
  albedo.sigma_mm = sigma_for_limit_between(1, 4);  // 0.114 mm, 2.5 px
  const double sharp_sigma_mm = sigma_for_limit_between(1, 6);  // 0.0905 mm, 1.9 px
  Scene relief = albedo;
  relief.mode = "relief";
  relief.gain_per_slope = 1.0;  // patch edge peaks at +-0.35 around 0.5
  std::vector<CaseSpec> cases;
  auto add = [&](std::string name, Scene s, auto&& setup) {
    CaseSpec c;
    c.name = std::move(name);
    c.scene = s;
    setup(c);
    cases.push_back(c);
  };
  add("fronto-parallel", albedo, [](CaseSpec&) {});
  add("rotated 30 deg", albedo, [&](CaseSpec& c) {
    c.pose.roll_deg = 30;
    c.scene.sigma_mm = sharp_sigma_mm;
  });
  add("tilted 25 deg", albedo, [](CaseSpec& c) { c.pose.tilt_deg = 25; });
  add("mirrored", albedo, [](CaseSpec& c) { c.pose.mirrored = true; c.pose.roll_deg = 4; });
  add("wide-angle off-centre", albedo, [](CaseSpec& c) {
    c.camera = "wide_angle";
    c.pose.shift_mm = {7, 4};  // the target's far corner ~38 deg off axis
    c.pose.distance_mm = 24;
    c.scene.sigma_mm = sigma_for_limit_between(1, 3);  // fewer px per mm off axis
  });
  add("40 dB noise", albedo, [](CaseSpec& c) { c.pose.roll_deg = 8; c.scene.snr_db = 40; c.scene.seed = 40; });
  add("20 dB noise", albedo, [](CaseSpec& c) {
    // Noise sigma = step / 10: with ink at 0.05 a quarter of the patch would
    // clip at 0 in any integer file (a truly clipped capture); grey ink and
    // ground keep every level > 5 sigma inside [0, 1].
    c.scene.ink_albedo = 0.25;
    c.scene.ground_albedo = 0.75;
    c.pose.roll_deg = 8;
    c.scene.snr_db = 20;
    c.scene.seed = 20;
  });
  add("32-bit float TIFF", albedo, [](CaseSpec& c) { c.extension = ".tif"; c.pose.roll_deg = -6; });
  add("light bars on dark", albedo, [&](CaseSpec& c) {
    c.scene.light_bars_on_dark = true;
    c.pose.roll_deg = 3;
    c.scene.sigma_mm = sharp_sigma_mm;
  });
  add("relief direct", relief, [](CaseSpec& c) { c.pose.roll_deg = 5; });
  add("relief mirrored", relief, [&](CaseSpec& c) {
    c.pose.mirrored = true;
    c.pose.roll_deg = 14;
    c.scene.light_azimuth_deg = -35;  // light from the other side
    c.scene.sigma_mm = sharp_sigma_mm;
  });
  add("2448x2048 roll 23 deg tilt 10 deg", albedo, [](CaseSpec& c) {
    c.camera = "pinhole5mp";
    c.pose.distance_mm = 30;
    c.pose.roll_deg = 23;
    c.pose.tilt_deg = 10;
    c.scene.sigma_mm = sigma_for_limit_between(3, 3);  // 0.032 mm, 2.2 px; limit 10.7 lp/mm at 3.3 px/bar
  });
  return cases;
}

const CaseSpec& issue_case(const std::string& name) {
  static const std::vector<CaseSpec> cases = issue_cases();
  for (const CaseSpec& c : cases)
    if (c.name == name) return c;
  throw std::invalid_argument("no case named " + name);
}

std::string env_measure_args() {
  const char* a = std::getenv("TACTRES_REFERENCE_MEASURE_ARGS");
  return a ? std::string(a) : std::string();
}

CaseResult measure_and_compare(const std::string& name, const fs::path& image, const fs::path& camera_model,
                               const Truth& truth, const fs::path& out_json, const std::string& extra_args) {
  CaseResult r;
  r.name = name;
  r.truth = truth;
  const fs::path log = out_json.string() + ".log";
  const std::string cmd = tactres_binary() + " measure '" + image.string() + "' --layout '" +
                          default_layout_path().string() + "' --camera '" + camera_model.string() + "' -o '" +
                          out_json.string() + "' " + extra_args + " " + env_measure_args() + " > '" +
                          log.string() + "' 2>&1";
  const auto t0 = std::chrono::steady_clock::now();
  r.exit_code = run_shell(cmd);
  r.measure_seconds = seconds_since(t0);
  if (!fs::exists(out_json)) {
    r.problem = "no measurement JSON; output: " + read_text(log);
    return r;
  }
  const nlohmann::json j = nlohmann::json::parse(read_text(out_json));
  r.usable = j.value("usable", false);
  if (j.contains("problem") && j["problem"].is_string()) r.problem = j["problem"].get<std::string>();
  if (j.contains("input") && j["input"].contains("transfer")) r.transfer = j["input"]["transfer"].get<std::string>();
  const nlohmann::json limits = j.value("limits", nlohmann::json());
  r.horizontal = limit_from(limits, "horizontal_bars");
  r.vertical = limit_from(limits, "vertical_bars");
  if (r.horizontal.interpolated_lp_per_mm)
    r.rel_error_h = *r.horizontal.interpolated_lp_per_mm / truth.horizontal_bars.interpolated_lp_per_mm - 1;
  if (r.vertical.interpolated_lp_per_mm)
    r.rel_error_v = *r.vertical.interpolated_lp_per_mm / truth.vertical_bars.interpolated_lp_per_mm - 1;
  if (j.contains("elements")) compare_elements(j["elements"], r);
  return r;
}

CaseResult run_case(const CaseSpec& spec, const fs::path& dir, const std::string& extra_args) {
  std::string stem = spec.name;
  for (char& ch : stem)
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  const Layout& layout = default_layout();
  const Camera camera = camera_named(spec.camera);
  fs::path camera_model = dir / (spec.camera + ".cameramodel");
  if (spec.camera == "wide_angle")
    camera_model = fs::path(TACTRES_SOURCE_DIR) / "examples/cameras/wide_angle.cameramodel";
  else if (!fs::exists(camera_model))
    camera.write_cameramodel(camera_model.string());

  const auto t0 = std::chrono::steady_clock::now();
  Image image = render_image(layout, camera, spec.pose, spec.scene);
  add_gaussian_noise(image, noise_sigma(layout, spec.scene), spec.scene.seed);
  const fs::path image_path = dir / (stem + spec.extension);
  write_image(image_path.string(), image);
  const Truth truth = make_truth(layout, camera, spec.pose, spec.scene.sigma_mm);
  std::ofstream(dir / (stem + ".truth.json")) << truth_json(truth, spec.pose, spec.scene, camera, layout).dump(2);
  const double render_seconds = seconds_since(t0);

  CaseResult r = measure_and_compare(spec.name, image_path, camera_model, truth, dir / (stem + ".json"), extra_args);
  r.render_seconds = render_seconds;
  return r;
}

const CaseResult& cached_case_result(const std::string& name, const std::string& extra_args) {
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.mutex);
  const std::string key = name + "|" + extra_args;
  auto it = c.results.find(key);
  if (it != c.results.end()) return it->second;
  if (!c.dir) c.dir = std::make_unique<TempDir>("cases");
  return c.results.emplace(key, run_case(issue_case(name), c.dir->path, extra_args)).first->second;
}

std::string summary_line(const CaseResult& r) {
  char buf[1024];
  auto pct = [](const std::optional<double>& v) { return v ? 100 * *v : NAN; };
  auto lim = [](const MeasuredLimit& L) { return L.interpolated_lp_per_mm ? *L.interpolated_lp_per_mm : NAN; };
  auto unc = [](const MeasuredLimit& L) { return L.uncertainty_lp_per_mm ? *L.uncertainty_lp_per_mm : NAN; };
  std::snprintf(buf, sizeof buf,
                "%-34s exit %d %s, %s | H true %.4f meas %.4f +- %.4f (%+.2f %%) | V true %.4f meas %.4f +- %.4f "
                "(%+.2f %%) | max|dm| %.4f over %d | falsely resolved %zu | render %.1f s, measure %.1f s",
                r.name.c_str(), r.exit_code, r.usable ? "usable" : ("UNUSABLE: " + r.problem).c_str(), r.transfer.c_str(),
                r.truth.horizontal_bars.interpolated_lp_per_mm, lim(r.horizontal), unc(r.horizontal),
                pct(r.rel_error_h), r.truth.vertical_bars.interpolated_lp_per_mm, lim(r.vertical), unc(r.vertical),
                pct(r.rel_error_v), r.max_abs_dm, r.elements_compared, r.falsely_resolved.size(), r.render_seconds,
                r.measure_seconds);
  return buf;
}

CleanCase render_clean_case(const std::string& name, const fs::path& dir, double snr_db) {
  CleanCase c;
  c.spec = issue_case(name);
  c.spec.scene.snr_db = 0;
  const Layout& layout = default_layout();
  const Camera camera = camera_named(c.spec.camera);
  c.camera_model = dir / (c.spec.camera + ".cameramodel");
  camera.write_cameramodel(c.camera_model.string());
  c.clean = render_image(layout, camera, c.spec.pose, c.spec.scene);
  c.truth = make_truth(layout, camera, c.spec.pose, c.spec.scene.sigma_mm);
  c.spec.scene.snr_db = snr_db;
  c.noise_sigma = noise_sigma(layout, c.spec.scene);
  return c;
}

}  // namespace reference::e2e
