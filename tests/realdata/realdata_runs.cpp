#include "realdata_runs.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <sys/wait.h>
#include <unistd.h>

#include <doctest/doctest.h>

namespace tactres_realdata {

bool realdata_absent() {
  if (fs::exists(kRealdata)) return false;
  MESSAGE("skipped: " << kRealdata.string() << " is absent (the real captures are never copied into the repo)");
  return true;
}

int element_index(int group, int element) { return 6 * group + element - 1; }

const fs::path& scratch_dir() {
  struct Scratch {
    fs::path path = fs::temp_directory_path() / ("tactres_realdata_" + std::to_string(::getpid()));
    Scratch() { fs::create_directories(path); }
    ~Scratch() {
      std::error_code ec;
      fs::remove_all(path, ec);
    }
  };
  static const Scratch scratch;
  return scratch.path;
}

// One CLI run per image, cached: several test cases read the same result.
const Run& measure_image(const fs::path& image) {
  static std::map<std::string, Run> cache;
  if (auto it = cache.find(image.string()); it != cache.end()) return it->second;
  const fs::path json_path = scratch_dir() / (image.filename().string() + ".json");
  fs::remove(json_path);  // never an earlier run's
  const std::string cmd = std::string(TACTRES_BINARY) + " measure '" + image.string() + "' --chart usaf1951 -o '" +
                          json_path.string() + "' > /dev/null 2>&1";
  Run r;
  const int status = std::system(cmd.c_str());
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  if (std::ifstream in(json_path); in) {
    std::stringstream ss;
    ss << in.rdbuf();
    // nlohmann rejects NaN and inf literals: a parse failure is a failure.
    try {
      r.j = json::parse(ss.str());
    } catch (const json::exception&) {
    }
  }
  return cache.emplace(image.string(), std::move(r)).first->second;
}

const Run& measure(const std::string& file) { return measure_image(kRealdata / file); }

json readings() {
  std::ifstream in(fs::path(TACTRES_SOURCE_DIR) / "tests" / "realdata" / "readings.json");
  REQUIRE(in);
  return json::parse(in);
}

bool absolute(const json& j) { return j.contains("chart") && j["chart"].value("indices", "") == "absolute"; }

void check_resolved_within_reading(const json& j, const json& im, const std::string& file) {
  if (!absolute(j)) return;
  for (const char* o : {"horizontal_bars", "vertical_bars"}) {
    const json& reading = im[o];
    if (reading.is_null() || !reading["finest_resolved"].contains("group")) continue;
    const json& fr = reading["finest_resolved"];
    const int limit = element_index(fr["group"], fr["element"]);
    std::set<int> seen_beyond;
    for (const json& b : reading.value("three_maxima_beyond", json::array()))
      seen_beyond.insert(element_index(b["group"], b["element"]));
    for (const json& e : j["elements"])
      if (e["orientation"] == o && e["resolved"] == true && !seen_beyond.count(element_index(e["group"], e["element"]))) {
        CAPTURE(file);
        CAPTURE(o);
        CAPTURE(e.dump());
        CHECK(element_index(e["group"], e["element"]) <= limit + 1);
      }
  }
}

std::optional<int> limit_from_reading(const json& j, const json& im, const char* o) {
  const json& reading = im[o];
  if (reading.is_null() || !reading["finest_resolved"].contains("group") || !absolute(j)) return std::nullopt;
  const json &fr = reading["finest_resolved"], &l = j["limits"][o];
  if (l["resolved_any"] != true) return std::nullopt;
  return element_index(l["group"], l["element"]) - element_index(fr["group"], fr["element"]);
}

Px size_of(const json& j) { return {j["input"]["width"].get<double>(), j["input"]["height"].get<double>()}; }

PixelMap resized_back(const json& copy, const json& original) {
  const Px from = size_of(copy), to = size_of(original);
  return [=](Px p) { return Px{(p.x + 0.5) * to.x / from.x - 0.5, (p.y + 0.5) * to.y / from.y - 0.5}; };
}

void check_named_alike(const json& copy, const json& original, const PixelMap& to_original, int& matched) {
  int here = 0;
  for (const json& e : copy["elements"]) {
    if (e["center_px"].is_null()) continue;
    const Px at = to_original({e["center_px"][0].get<double>(), e["center_px"][1].get<double>()});
    const json* nearest = nullptr;
    double nearest_bars = 1.5;
    for (const json& o : original["elements"]) {
      if (o["center_px"].is_null() || o["orientation"] != e["orientation"]) continue;
      const double bars = std::hypot(o["center_px"][0].get<double>() - at.x, o["center_px"][1].get<double>() - at.y) /
                          o["px_per_bar"].get<double>();
      if (bars < nearest_bars) nearest_bars = bars, nearest = &o;
    }
    if (!nearest) continue;
    ++here;
    CAPTURE(e.dump());
    CAPTURE(nearest->dump());
    CHECK(element_index(e["group"], e["element"]) == element_index((*nearest)["group"], (*nearest)["element"]));
  }
  CHECK(here > 0);
  matched += here;
}

}  // namespace tactres_realdata
