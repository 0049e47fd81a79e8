#pragma once
// Hand-made measurement JSONs (as measure writes them: "tactres.measurement/1",
// or /2 with the detectability limit) for the reports unit tests: every
// number in them is chosen so that the expected table can be worked out by
// hand.

#include <unistd.h>

#include <cmath>
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

// The /2 extras of one orientation (profiles/detectability.h). The reported
// limit stays HandMeasurement::h / v: give it the coarser of the two, as
// measure does.
struct HandParts {
  std::optional<HandLimit> optical;        // default: the reported limit
  std::optional<HandLimit> detectability;  // default: every element detectable
  bool light_limited = false;              // "limited_by": "light/noise"
  std::optional<double> light_needed = 0.25;
};

// Makes `reported` and `parts` a light-limited orientation: optics would
// reach `optical_interp` lp/mm but the bars sink into the noise at the
// reported (detectability) limit; `light_needed` is the exposure factor.
inline void limit_by_light(const HandLimit& reported, double optical_interp, double light_needed, HandParts& parts) {
  HandLimit optical = reported;
  optical.interp = optical_interp;
  optical.lp_per_mm = optical_interp * 0.95;  // its discrete element, just below
  optical.element = 6;
  parts.optical = optical;
  parts.detectability = reported;
  parts.light_limited = true;
  parts.light_needed = light_needed;
}

struct HandMeasurement {
  std::string design = "A";
  HandLimit h, v;
  double threshold = 0.10;
  std::string layout = "target/layout.json";
  std::string layout_sha1;  // written when not empty
  bool usable = true;
  std::string problem;
  double nyquist_lp_per_mm = 10.0;
  // Element series: 1, 2, 4, 8 lp/mm in both orientations (the layout's
  // identity); `finest_lp_per_mm` changes the last one.
  double finest_lp_per_mm = 8.0;
  // Schema 2 adds the two limits per orientation and each element's CNR.
  int schema = 1;
  HandParts h_parts, v_parts;
  double detectability_k = 5.0;
  double cnr[4] = {400.0, 120.0, 20.0, 1.5};  // per element, both orientations
};

// limits.<orientation> of a /2 file: the reported fields plus the parts.
inline nlohmann::json hand_parts(const HandLimit& reported, const HandParts& p, double k, double finest_lp_per_mm) {
  nlohmann::json j = hand_limit(reported);
  HandLimit all;  // every element detectable: the finest, a lower bound
  all.group = 3;
  all.lp_per_mm = finest_lp_per_mm;
  all.beyond_finest = true;
  j["limited_by"] = p.light_limited ? "light/noise" : "optics";
  j["optical"] = hand_limit(p.optical.value_or(reported));
  j["detectability"] = hand_limit(p.detectability.value_or(all));
  j["detectability"]["k"] = k;
  j["light_needed_factor"] = p.light_needed ? nlohmann::json(*p.light_needed) : nlohmann::json();
  return j;
}

inline nlohmann::json hand_measurement(const HandMeasurement& m) {
  nlohmann::json j;
  const bool v2 = m.schema == 2;
  j["schema"] = v2 ? "tactres.measurement/2" : "tactres.measurement/1";
  j["tactres_version"] = "0.1.0";
  j["image"] = m.design + ".png";
  j["design"] = m.design;
  j["layout"] = m.layout;
  if (!m.layout_sha1.empty()) j["layout_sha1"] = m.layout_sha1;
  j["usable"] = m.usable;
  j["problem"] = m.problem.empty() ? nlohmann::json() : nlohmann::json(m.problem);
  j["criterion"] = {{"threshold", m.threshold}, {"significance_z", 2.0}};
  if (v2) j["criterion"]["detectability_k"] = m.detectability_k;
  j["preset"] = "balanced";
  j["camera"] = {{"model", ""}, {"distortion_corrected", false}};
  j["pose"] = nullptr;
  j["reference"] = nullptr;
  j["nyquist_lp_per_mm"] = {{"horizontal_bars", m.usable ? m.nyquist_lp_per_mm : 0.0},
                            {"vertical_bars", m.usable ? m.nyquist_lp_per_mm : 0.0}};
  HandLimit nothing;  // a failed capture has no limits
  nothing.resolved = false;
  if (!v2) {
    j["limits"] = {{"horizontal_bars", hand_limit(m.usable ? m.h : nothing)},
                   {"vertical_bars", hand_limit(m.usable ? m.v : nothing)}};
  } else {
    const HandParts none{nothing, nothing, false, std::nullopt};
    j["limits"] = {
        {"horizontal_bars", hand_parts(m.usable ? m.h : nothing, m.usable ? m.h_parts : none, m.detectability_k,
                                       m.finest_lp_per_mm)},
        {"vertical_bars", hand_parts(m.usable ? m.v : nothing, m.usable ? m.v_parts : none, m.detectability_k,
                                     m.finest_lp_per_mm)}};
  }
  nlohmann::json els = nlohmann::json::array();
  if (m.usable) {
    const double f[4] = {1.0, 2.0, 4.0, m.finest_lp_per_mm};
    const double mm[4] = {0.9, 0.6, 0.2, 0.02};
    for (int k = 0; k < 4; ++k)
      for (const char* o : {"horizontal_bars", "vertical_bars"}) {
        nlohmann::json e = {{"group", k},
                            {"element", 1},
                            {"orientation", o},
                            {"lp_per_mm", f[k]},
                            {"px_per_bar", 10.0 / f[k]},
                            {"m", mm[k]},
                            {"m_sigma", 0.01},
                            {"psf_shape_beta", 2.0},
                            {"chi2_reduced", 1.0},
                            {"status", "ok"},
                            {"resolved", mm[k] >= m.threshold}};
        if (v2) {
          const double pixels = 5 * (10.0 / f[k]) * (10.0 / f[k]);
          e["signal"] = m.cnr[k] * 0.01 / std::sqrt(pixels);  // so that signal sqrt(N) / noise = cnr
          e["noise_sd"] = 0.01;
          e["pixels_per_bar"] = pixels;
          e["cnr"] = m.cnr[k];
          e["cnr_sigma"] = 0.05 * m.cnr[k];
          e["detectable"] = m.cnr[k] >= m.detectability_k;
        }
        els.push_back(e);
      }
  }
  j["elements"] = els;
  j["timing_seconds"] = {{"decode", 0.01}};
  return j;
}

}  // namespace tactres::testing
