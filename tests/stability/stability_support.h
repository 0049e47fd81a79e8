#pragma once
// Shared checks of the stability suite (issue 7, docs/STABILITY.md): every
// hard case and every property case asserts that the outputs are finite,
// that the graded statuses are consistent, and (through the CLI) that the
// exit code is the documented one.

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <spawn.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include <doctest/doctest.h>
#include <nlohmann/json.hpp>

#include "scene_fixtures.h"
#include "tactres/measure/measurement_io.h"
#include "tactres/reports/measurement_record.h"
#include "tactres/util/atomic_file.h"
#include "tactres/targets/layout_json.h"

extern char** environ;

namespace tactres::stability {

// Every number in a JSON document; returns the paths of non-finite ones.
inline void collect_non_finite(const nlohmann::json& j, const std::string& path, std::vector<std::string>& bad) {
  if (j.is_number_float() && !std::isfinite(j.get<double>())) bad.push_back(path);
  if (j.is_object())
    for (auto it = j.begin(); it != j.end(); ++it) collect_non_finite(*it, path + "." + it.key(), bad);
  if (j.is_array())
    for (std::size_t i = 0; i < j.size(); ++i) collect_non_finite(j[i], path + "[" + std::to_string(i) + "]", bad);
}

// The paths at which two JSON documents differ (for readable failures).
// Numbers may differ by `rel_tol` relative (0: bit for bit); everything
// else (statuses, flags, groups, nulls) must match exactly.
inline void json_differences(const nlohmann::json& a, const nlohmann::json& b, const std::string& path,
                             std::vector<std::string>& out, double rel_tol = 0) {
  if (a.is_number() && b.is_number() && rel_tol > 0) {
    const double x = a.get<double>(), y = b.get<double>();
    if (!(std::abs(x - y) <= rel_tol * std::max(std::abs(x), std::abs(y))))
      out.push_back(path + ": " + a.dump() + " vs " + b.dump());
    return;
  }
  if (a.type() != b.type() || (!a.is_structured() && a != b)) {
    out.push_back(path + ": " + a.dump() + " vs " + b.dump());
    return;
  }
  if (a.is_object()) {
    for (auto it = a.begin(); it != a.end(); ++it)
      if (b.contains(it.key())) json_differences(*it, b[it.key()], path + "." + it.key(), out, rel_tol);
      else out.push_back(path + "." + it.key() + ": missing in the second");
    for (auto it = b.begin(); it != b.end(); ++it)
      if (!a.contains(it.key())) out.push_back(path + "." + it.key() + ": missing in the first");
  } else if (a.is_array()) {
    if (a.size() != b.size()) out.push_back(path + ": sizes " + std::to_string(a.size()) + " vs " + std::to_string(b.size()));
    for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i)
      json_differences(a[i], b[i], path + "[" + std::to_string(i) + "]", out, rel_tol);
  }
}

inline std::vector<std::string> json_diff(const nlohmann::json& a, const nlohmann::json& b, double rel_tol = 0) {
  std::vector<std::string> d;
  json_differences(a, b, "", d, rel_tol);
  return d;
}

inline std::string json_diff_text(const nlohmann::json& a, const nlohmann::json& b, double rel_tol = 0,
                                  std::size_t max_lines = 12) {
  const std::vector<std::string> d = json_diff(a, b, rel_tol);
  std::string s = std::to_string(d.size()) + " difference(s)";
  for (std::size_t i = 0; i < d.size() && i < max_lines; ++i) s += "\n  " + d[i];
  return s;
}

inline bool finite_all(std::initializer_list<double> v) {
  for (double x : v)
    if (!std::isfinite(x)) return false;
  return true;
}

struct Measured {
  Measurement m;
  nlohmann::json json;
};

// The measurement's JSON as `tactres measure` writes it.
inline nlohmann::json to_json(const Measurement& m, const LoadedImage& img, const MeasureOptions& options) {
  MeasurementContext ctx;
  ctx.image = "capture";
  ctx.design = "stability";
  ctx.layout = "layout.json";
  ctx.tactres_version = "test";
  ctx.loaded = &img;
  ctx.options = &options;
  return measurement_to_json(m, ctx);
}

// The three assertions every case makes about a measurement in process:
// (1) every number finite, in the struct (so that the writer's NaN -> null
// guard hides nothing) and in the JSON; (2) the statuses are consistent
// with the criterion; (3) the JSON is one the reports accept.
inline void check_measurement(const Measurement& m, const nlohmann::json& j, const Criterion& c = {}) {
  std::vector<std::string> bad;
  collect_non_finite(j, "measurement", bad);
  CHECK_MESSAGE(bad.empty(), "non-finite JSON numbers: " << (bad.empty() ? "" : bad.front()));
  const std::string text = j.dump();
  CHECK(finite_all({m.nyquist_h_lp_per_mm, m.nyquist_v_lp_per_mm}));
  CHECK(m.usable == m.problem.empty());
  if (m.pose.usable) {
    for (double v : m.pose.rt_camera_from_target_mm) CHECK(std::isfinite(v));
    CHECK(std::isfinite(m.pose.rms_px));
  }
  if (m.reference.usable) {
    CHECK(finite_all({m.reference.vertical_bars.contrast, m.reference.vertical_bars.contrast_sigma, m.reference.horizontal_bars.contrast,
                      m.reference.horizontal_bars.contrast_sigma, m.reference.vertical_bars.chi2_reduced, m.reference.horizontal_bars.chi2_reduced}));
    CHECK(m.reference.vertical_bars.contrast_sigma > 0);
    CHECK(m.reference.horizontal_bars.contrast_sigma > 0);
  }
  for (const ElementResult& e : m.elements) {
    CAPTURE(e.group);
    CAPTURE(e.element);
    CHECK(finite_all({e.lp_per_mm, e.px_per_bar, e.m, e.m_sigma, e.beta, e.chi2_reduced}));
    if (e.status == ElementStatus::ok) {
      CHECK(e.m_sigma > 0);
    } else {
      CHECK_FALSE(e.resolved);
      CHECK(e.m == 0);
    }
    if (e.resolved) {
      CHECK(e.m >= c.threshold);
      CHECK(e.m - c.significance_z * e.m_sigma > 0);
    }
    if (e.px_per_bar > 0 && e.px_per_bar < 1.0) CHECK_FALSE(e.resolved);  // beyond Nyquist
  }
  for (const Limit* l : {&m.horizontal, &m.vertical}) {
    CHECK(std::isfinite(l->lp_per_mm));
    if (l->interpolated_lp_per_mm) {
      CHECK(std::isfinite(*l->interpolated_lp_per_mm));
      CHECK(l->uncertainty_lp_per_mm);
      if (l->uncertainty_lp_per_mm) {
        CHECK(std::isfinite(*l->uncertainty_lp_per_mm));
        CHECK(*l->uncertainty_lp_per_mm > 0);
      }
    }
    if (!m.usable) CHECK_FALSE(l->any_resolved);
  }
  try {
    const MeasurementRecord r = measurement_from_json(nlohmann::json::parse(text), "stability");
    CHECK(r.usable == m.usable);
  } catch (const std::exception& e) {
    FAIL_CHECK("the reports refuse measure's own JSON: " << e.what());
  }
}

inline Measured measure_checked(const LoadedImage& img, const CameraModel* camera,
                                const MeasureOptions& options = MeasureOptions::for_preset(Preset::balanced)) {
  Measured out;
  out.m = measure_capture(img, testing::default_layout(), camera, options);
  out.json = to_json(out.m, img, options);
  check_measurement(out.m, out.json, options.criterion);
  return out;
}

// An in-memory capture as load_image would return it for a float file.
inline LoadedImage float_image(const cv::Mat& lum) {
  LoadedImage img;
  lum.convertTo(img.luminance, CV_32F);
  img.width = lum.cols;
  img.height = lum.rows;
  img.channels = 1;
  img.pixel_format = "float";
  img.bits_per_sample = 32;
  img.transfer = {TransferCurve::linear(), "test", false};
  for (int y = 0; y < img.luminance.rows; ++y)
    for (int x = 0; x < img.luminance.cols; ++x)
      if (!std::isfinite(img.luminance.at<float>(y, x))) {
        ++img.non_finite_pixels;
        img.luminance.at<float>(y, x) = std::numeric_limits<float>::quiet_NaN();
      }
  return img;
}

// An in-memory capture as load_image returns it for an integer file of
// `bits` significant bits (DN from the sensor effect).
inline LoadedImage integer_image(const cv::Mat& dn, int bits) {
  LoadedImage img;
  dn.convertTo(img.luminance, CV_32F, 1.0 / ((1 << bits) - 1));
  img.width = dn.cols;
  img.height = dn.rows;
  img.channels = 1;
  img.pixel_format = bits > 8 ? "uint16" : "uint8";
  img.bits_per_sample = bits > 8 ? 16 : 8;
  img.integer_format = true;
  img.transfer = {TransferCurve::linear(), "test", false};
  img.rounding.code_step = 1.0 / ((1 << bits) - 1);
  img.saturation_level = 1.0;
  return img;
}

// ---------------------------------------------------------------- the CLI

struct CliRun {
  int exit_code = -1;       // -1 if it did not exit normally
  bool signalled = false;   // killed by a signal: a crash
  long max_rss_kb = 0;      // the child's peak resident set (getrusage via wait4)
  std::string err;
};

// Runs `tactres ARGS...` with stdout and stderr captured to `dir`, without a
// shell, and returns its exit status and peak memory.
inline CliRun run_tactres(const std::vector<std::string>& args, const std::filesystem::path& dir) {
  std::vector<std::string> argv_s = {TACTRES_BINARY};
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& s : argv_s) argv.push_back(s.data());
  argv.push_back(nullptr);
  const std::string err_path = (dir / "stderr.txt").string();
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&fa, 2, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = 0;
  CliRun r;
  const int rc = posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  REQUIRE(rc == 0);
  int status = 0;
  rusage ru{};
  REQUIRE(wait4(pid, &status, 0, &ru) == pid);
  r.max_rss_kb = ru.ru_maxrss;
  r.signalled = WIFSIGNALED(status);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream f(err_path);
  r.err.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  return r;
}

// `tactres measure IMAGE --layout L -o OUT.json [extra]`; checks that it did
// not crash, that the exit code is `expected`, and that the JSON it wrote
// (always, for exit 0-2) is finite and readable by the reports.
inline CliRun measure_cli(const std::filesystem::path& image, const std::filesystem::path& layout,
                          const std::filesystem::path& dir, int expected, std::vector<std::string> extra = {}) {
  const std::filesystem::path out = dir / "cli-out.json";
  std::filesystem::remove(out);
  std::vector<std::string> args = {"measure", image.string(), "--layout", layout.string(), "-o", out.string()};
  args.insert(args.end(), extra.begin(), extra.end());
  CliRun r = run_tactres(args, dir);
  CAPTURE(r.err);
  CHECK_FALSE(r.signalled);
  CHECK(r.exit_code == expected);
  if (r.exit_code >= 0 && r.exit_code <= 2) {
    REQUIRE(std::filesystem::exists(out));
    const nlohmann::json j = nlohmann::json::parse(read_file(out));
    std::vector<std::string> bad;
    collect_non_finite(j, "cli", bad);
    CHECK(bad.empty());
    CHECK(j["usable"].get<bool>() == (r.exit_code != 2));
    CHECK_NOTHROW(measurement_from_json(j, out.string()));
  } else {
    CHECK_FALSE(std::filesystem::exists(out));
  }
  return r;
}

inline std::string limit_text(const Limit& l) {
  if (!l.any_resolved) return "none resolved";
  std::string s = "G" + std::to_string(l.group) + "E" + std::to_string(l.element);
  if (l.interpolated_lp_per_mm)
    s += " (" + std::to_string(*l.interpolated_lp_per_mm) + " +- " +
         std::to_string(l.uncertainty_lp_per_mm.value_or(0)) + " lp/mm)";
  return s;
}

inline int count_status(const Measurement& m, ElementStatus s) {
  int n = 0;
  for (const ElementResult& e : m.elements) n += e.status == s ? 1 : 0;
  return n;
}

inline int count_resolved(const Measurement& m) {
  int n = 0;
  for (const ElementResult& e : m.elements) n += e.resolved ? 1 : 0;
  return n;
}

// How many times the property suites repeat: 1 in the normal suite; the
// opt-in long run (label stability-long) sets TACTRES_STABILITY_SCALE.
inline int stability_scale() {
  const char* s = std::getenv("TACTRES_STABILITY_SCALE");
  const int v = s ? std::atoi(s) : 1;
  return v >= 1 ? v : 1;
}

}  // namespace tactres::stability
