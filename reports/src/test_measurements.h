#pragma once
// Hand-made measurement JSONs ("tactres.measurement/1", as measure writes
// them) for the reports unit tests: every number in them is chosen so that
// the expected table can be worked out by hand.

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

namespace tactres::testing {

// A fresh folder under the system temp dir, removed at scope exit.
struct ReportTempDir {
  std::filesystem::path path;
  explicit ReportTempDir(const std::string& tag) {
    static int counter = 0;
    path = std::filesystem::temp_directory_path() /
           ("tactres-" + tag + "-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
    std::filesystem::create_directories(path);
  }
  ~ReportTempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  ReportTempDir(const ReportTempDir&) = delete;
  ReportTempDir& operator=(const ReportTempDir&) = delete;

  std::filesystem::path write(const std::string& name, const std::string& text) const {
    std::ofstream(path / name, std::ios::binary) << text;
    return path / name;
  }
};

struct HandLimit {
  bool resolved = true;
  int group = 2, element = 1;
  double lp_per_mm = 4.0;                // discrete
  std::optional<double> interp, sigma;   // interpolated and its 1-sigma
  bool beyond_finest = false;
};

inline nlohmann::json hand_limit(const HandLimit& l) {
  auto opt = [](std::optional<double> v) { return v ? nlohmann::json(*v) : nlohmann::json(); };
  return {{"resolved_any", l.resolved},
          {"group", l.resolved ? nlohmann::json(l.group) : nlohmann::json()},
          {"element", l.resolved ? nlohmann::json(l.element) : nlohmann::json()},
          {"lp_per_mm", l.resolved ? nlohmann::json(l.lp_per_mm) : nlohmann::json()},
          {"interpolated_lp_per_mm", opt(l.interp)},
          {"uncertainty_lp_per_mm", opt(l.sigma)},
          {"beyond_finest", l.beyond_finest}};
}

struct HandMeasurement {
  std::string design = "A";
  HandLimit h, v;
  double threshold = 0.10;
  std::string layout = "target/layout.json";
  bool usable = true;
  std::string problem;
  double nyquist_lp_per_mm = 10.0;
  // Element series: 1, 2, 4, 8 lp/mm in both orientations (the layout's
  // identity); `finest_lp_per_mm` changes the last one.
  double finest_lp_per_mm = 8.0;
};

inline nlohmann::json hand_measurement(const HandMeasurement& m) {
  nlohmann::json j;
  j["schema"] = "tactres.measurement/1";
  j["tactres_version"] = "0.1.0";
  j["image"] = m.design + ".png";
  j["design"] = m.design;
  j["layout"] = m.layout;
  j["usable"] = m.usable;
  j["problem"] = m.problem.empty() ? nlohmann::json() : nlohmann::json(m.problem);
  j["criterion"] = {{"threshold", m.threshold}, {"significance_z", 2.0}};
  j["preset"] = "balanced";
  j["camera"] = {{"model", ""}, {"distortion_corrected", false}};
  j["pose"] = nullptr;
  j["reference"] = nullptr;
  j["nyquist_lp_per_mm"] = {{"horizontal_bars", m.usable ? m.nyquist_lp_per_mm : 0.0},
                            {"vertical_bars", m.usable ? m.nyquist_lp_per_mm : 0.0}};
  HandLimit nothing;  // a failed capture has no limits
  nothing.resolved = false;
  j["limits"] = {{"horizontal_bars", hand_limit(m.usable ? m.h : nothing)},
                 {"vertical_bars", hand_limit(m.usable ? m.v : nothing)}};
  nlohmann::json els = nlohmann::json::array();
  if (m.usable) {
    const double f[4] = {1.0, 2.0, 4.0, m.finest_lp_per_mm};
    const double mm[4] = {0.9, 0.6, 0.2, 0.02};
    for (int k = 0; k < 4; ++k)
      for (const char* o : {"horizontal_bars", "vertical_bars"})
        els.push_back({{"group", k},
                       {"element", 1},
                       {"orientation", o},
                       {"lp_per_mm", f[k]},
                       {"px_per_bar", 10.0 / f[k]},
                       {"m", mm[k]},
                       {"m_sigma", 0.01},
                       {"psf_shape_beta", 2.0},
                       {"chi2_reduced", 1.0},
                       {"status", "ok"},
                       {"resolved", mm[k] >= m.threshold}});
  }
  j["elements"] = els;
  j["timing_seconds"] = {{"decode", 0.01}};
  return j;
}

}  // namespace tactres::testing
