// Chart mode on real photographs and microscope frames of USAF-1951 charts
// (../shared/realdata, see its README), against careful visual readings
// kept beside this file (readings.json; how they were made: READINGS.md).
// The images are never copied into the repository: the suite skips, saying
// so, when the folder is absent.
//
// What is asserted for every capture, original bytes and 16-bit copy alike:
// - the exit code is 0, 1 or 2, and the JSON parses with no NaN/inf;
// - every graded element (status other than ok) has a note saying why;
// - with absolute indices, no element is called resolved more than one
//   element beyond the reading.
// The agreement with the readings (discrete limit within one element,
// absolute identification) is measured and printed, and must not fall
// below the level reached so far (kMinAgreement); the goal is 90 %.
// Turned by 90 or 180 deg or mirrored, or set down askew (resampled), the
// labelled captures must never be identified differently; saved as JPEG
// they must be identified as the originals and read within one element of
// them.

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <set>
#include <string>

#include <sys/wait.h>
#include <unistd.h>

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <doctest/doctest.h>
#include <nlohmann/json.hpp>

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// Share of the readings the measurement agrees with so far (a floor against
// regressions; raise it as chart mode improves).
constexpr double kMinAgreement = 0.89;  // 26 of 29 on 2026-12-02 (session 30; 25 in sessions 19-29; 23 in sessions 17-18; 21 in sessions 15-16, 18 in session 14, 17 in sessions 11-13, 16 in session 10, 15 in session 9, 12 in session 8)
// Labelled captures anchored absolute (the goal: every one whose numbers
// are legible); a floor against regressions.
constexpr int kMinIdentified = 7;  // dev_01, dev_02, dev_03, dev_04, dev_05, dev_11, dev_14 on 2026-11-27

const fs::path kRealdata = fs::path(TACTRES_SOURCE_DIR) / ".." / "shared" / "realdata";

int element_index(int group, int element) { return 6 * group + element - 1; }

struct Run {
  int exit_code = -1;
  std::optional<json> j;
};

// This process's scratch folder (the JSON files, and the turned copies of
// the captures), removed when the process ends.
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

}  // namespace

namespace {

void check_exit_codes_and_json() {
  const json all = readings();
  for (const json& im : all["images"])
    for (const char* key : {"file", "orig"}) {
      const std::string file = im[key];
      CAPTURE(file);
      const Run& r = measure(file);
      CHECK((r.exit_code == 0 || r.exit_code == 1 || r.exit_code == 2));
      CHECK(r.j.has_value());
      // Every graded element says why. An ok one's model-free dip reading
      // is m itself where m came from the dips, and none is kept for any
      // other status.
      if (r.j && r.j->contains("elements"))
        for (const json& e : (*r.j)["elements"]) {
          CAPTURE(e.dump());
          if (e["status"] != "ok") {
            CHECK((e["note"].is_string() && !e["note"].get<std::string>().empty()));
            CHECK(e["m_dips"].is_null());
          } else if (e["m_source"] == "gap_dips") {
            CHECK(e["m_dips"] == e["m"]);
          }
        }
      // Every element placed but not found is listed, and is measured.
      if (!r.j || !r.j->contains("chart") || !(*r.j)["chart"].value("found", false)) continue;
      const json& chart = (*r.j)["chart"];
      CHECK(chart["placed_elements"].size() == chart["predicted_elements"].get<size_t>());
      for (const json& p : chart["placed_elements"]) {
        int measured = 0;
        for (const json& e : (*r.j)["elements"]) measured += e["group"] == p["group"] && e["element"] == p["element"];
        CHECK(measured == 2);
      }
    }
}

// With absolute indices, no element of `j` called resolved more than one
// element beyond the reading `im` (an entry of readings.json). Beyond the
// chain, elements whose own profiles show three maxima (READINGS.md,
// `three_maxima_beyond`) may be resolved on their own.
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

void check_nothing_resolved_beyond_reading() {
  const json all = readings();
  for (const json& im : all["images"])
    for (const char* key : {"file", "orig"}) {
      const std::string file = im[key];
      const Run& r = measure(file);
      if (r.j) check_resolved_within_reading(*r.j, im, file);
    }
}

// How many elements the discrete limit of `j` in orientation `o` lies
// from the reading `im`'s; nullopt without a reading there, absolute
// indices, or anything resolved.
std::optional<int> limit_from_reading(const json& j, const json& im, const char* o) {
  const json& reading = im[o];
  if (reading.is_null() || !reading["finest_resolved"].contains("group") || !absolute(j)) return std::nullopt;
  const json &fr = reading["finest_resolved"], &l = j["limits"][o];
  if (l["resolved_any"] != true) return std::nullopt;
  return element_index(l["group"], l["element"]) - element_index(fr["group"], fr["element"]);
}

void check_agreement() {
  int readings_n = 0, agree = 0, identified = 0, labelled = 0;
  std::string table;
  const json all = readings();
  for (const json& im : all["images"]) {
    const std::string file = im["orig"];
    const Run& r = measure(file);
    const bool single = im["identification"] == "single_element";
    const bool usable = r.j && (*r.j)["usable"] == true;
    if (!single) {
      ++labelled;
      identified += usable && absolute(*r.j);
    }
    for (const char* o : {"horizontal_bars", "vertical_bars"}) {
      const json& reading = im[o];
      if (reading.is_null()) continue;
      const json& fr = reading["finest_resolved"];
      ++readings_n;
      std::string got = usable ? "relative" : "unusable";
      bool ok = false;
      if (usable && single) {
        // One element in view: it must be measured and called resolved. A
        // frame that holds one triplet only (dev_15/16) is measured in the
        // image's orientation: nothing in it but a digit's fragment says
        // which of the element's triplets it is (READINGS.md: "either way
        // it is resolved"), so either orientation counts there.
        const bool one_triplet = (*r.j)["chart"].value("single_pattern", false);
        int resolved = 0;
        for (const json& e : (*r.j)["elements"])
          resolved += (one_triplet || e["orientation"] == o) && e["resolved"] == true;
        ok = resolved >= 1;
        got = ok ? "resolved" : "not resolved";
      } else if (usable && absolute(*r.j)) {
        const json& l = (*r.j)["limits"][o];
        if (const std::optional<int> d = limit_from_reading(*r.j, im, o)) {
          ok = std::abs(*d) <= 1;
          got = "G" + std::to_string(int(l["group"])) + "E" + std::to_string(int(l["element"]));
        } else {
          got = "nothing resolved";
        }
      }
      agree += ok;
      table += "  " + file + " " + o + ": reading " +
               (fr.contains("element") ? "G" + std::to_string(int(fr["group"])) + "E" + std::to_string(int(fr["element"]))
                                       : std::string("?")) +
               ", measured " + got + (ok ? "  [agrees]" : "") + "\n";
    }
  }
  const double share = readings_n ? double(agree) / readings_n : 0;
  MESSAGE("realdata readings: " << agree << " of " << readings_n << " agree within one element (" << 100 * share
                                << " %); absolute identification on " << identified << " of " << labelled
                                << " labelled captures\n"
                                << table);
  CHECK(share >= kMinAgreement);
  CHECK(identified >= kMinIdentified);
}

}  // namespace

// One test case, so that each capture is measured once (the runs are cached
// within the process).
TEST_CASE("real chart captures against the visual readings") {
  if (!fs::exists(kRealdata)) {
    MESSAGE("skipped: " << kRealdata.string() << " is absent (the real captures are never copied into the repo)");
    return;
  }
  SUBCASE("exit 0, 1 or 2 and a JSON with no NaN") { check_exit_codes_and_json(); }
  SUBCASE("nothing called resolved more than one element beyond the reading") {
    check_nothing_resolved_beyond_reading();
  }
  SUBCASE("agreement within one element") { check_agreement(); }
}

namespace {

// `image` turned or mirrored, its code values as read (a copy in the
// scratch folder, never in the repo): ImageBufAlgo moves pixels only.
// OpenImageIO may tag the copy with the colour space it assumed (sRGB for
// an untagged 8-bit PNG), which tactres decodes alike.
fs::path transformed(const fs::path& image, const std::string& how) {
  namespace oiio = OIIO;
  const oiio::ImageBuf in(image.string());
  oiio::ImageBuf out = how == "turned_90"    ? oiio::ImageBufAlgo::rotate90(in)
                       : how == "turned_180" ? oiio::ImageBufAlgo::rotate180(in)
                                             : oiio::ImageBufAlgo::flop(in);
  const fs::path path = scratch_dir() / (image.stem().string() + "_" + how + image.extension().string());
  REQUIRE_MESSAGE(out.write(path.string()), out.geterror());
  return path;
}

}  // namespace

// The printed numbers are read upright as the arrangement turns them: a
// capture turned by 90 or 180 deg or mirrored (pixels moved, nothing else)
// must never be identified differently, and should be identified as it
// is. (dev_03 turned 180 deg or mirrored stayed relative: its one group
// number read, the "4" above G4E1, sat 0.3 bar widths off its band's
// middle and lost its top third. The fibre-bundle frame dev_02 turned by
// 90 or 180 deg stays relative: under its honeycomb the "7" reads as an 8
// in one of its three ways.)
constexpr int kMinTransformedIdentified = 16;  // of 18 on 2026-11-27

TEST_CASE("real chart captures turned or mirrored are never identified differently") {
  if (!fs::exists(kRealdata)) {
    MESSAGE("skipped: " << kRealdata.string() << " is absent (the real captures are never copied into the repo)");
    return;
  }
  int compared = 0, identified = 0;
  std::string relative;
  for (const std::string file : {"dev_01_orig.tif", "dev_02_orig.tif", "dev_03_orig.png", "dev_04_orig.png",
                                 "dev_05_orig.png", "dev_14_orig.png"}) {
    const Run& original = measure(file);
    REQUIRE(original.j);
    REQUIRE(absolute(*original.j));  // as the agreement test requires of these
    const json& largest = (*original.j)["chart"]["largest_element"];
    for (const std::string how : {"turned_90", "turned_180", "mirrored"}) {
      const Run& r = measure_image(transformed(kRealdata / file, how));
      CAPTURE(file);
      CAPTURE(how);
      REQUIRE(r.j);
      ++compared;
      if (!absolute(*r.j)) {
        relative += " " + file + " " + how;
        continue;
      }
      ++identified;
      const json& got = (*r.j)["chart"]["largest_element"];
      CHECK(got["group"] == largest["group"]);
      CHECK(got["element"] == largest["element"]);
      // The same element: its period as found (pixels moved only).
      CHECK(got["period_px"].get<double>() == doctest::Approx(largest["period_px"].get<double>()).epsilon(0.05));
    }
  }
  MESSAGE("turned or mirrored: " << identified << " of " << compared << " identified as the original; relative:"
                                 << (relative.empty() ? " none" : relative));
  CHECK(compared == 18);
  CHECK(identified >= kMinTransformedIdentified);
}

namespace {

// `image` saved as a JPEG of quality 85 (its first three channels at most,
// 8 bits), as captures are often shared: in the scratch folder, never in
// the repo.
fs::path as_jpeg(const fs::path& image) {
  namespace oiio = OIIO;
  const oiio::ImageBuf in(image.string());
  const int channels = std::min(in.nchannels(), 3);
  oiio::ImageBuf out = oiio::ImageBufAlgo::channels(in, channels, {});
  out.specmod().attribute("Compression", "jpeg:85");
  const fs::path path = scratch_dir() / (image.stem().string() + "_q85.jpg");
  REQUIRE_MESSAGE(out.write(path.string(), oiio::TypeDesc::UINT8), out.geterror());
  return path;
}

}  // namespace

// Saved as a JPEG of quality 85, a labelled capture must be identified as
// the original and read within one element of it in each orientation. (Its
// 8x8 blocks move a binarised bar's edge by a fraction of a pixel: a JPEG
// copy of dev_04 found G6E3 H's triplet one period down its column, in its
// lower two bars and the shoulder of the ground below them, and its limit
// fell from G6E5 to G6E2 until such a slip was looked for:
// PlacementStore::unslipped.)
TEST_CASE("real chart captures saved as JPEG read as the originals") {
  if (!fs::exists(kRealdata)) {
    MESSAGE("skipped: " << kRealdata.string() << " is absent (the real captures are never copied into the repo)");
    return;
  }
  int compared = 0, identified = 0;
  for (const std::string file : {"dev_01_orig.tif", "dev_02_orig.tif", "dev_03_orig.png", "dev_04_orig.png",
                                 "dev_05_orig.png", "dev_11_orig.png", "dev_14_orig.png"}) {
    const Run& original = measure(file);
    REQUIRE(original.j);
    REQUIRE(absolute(*original.j));
    const Run& r = measure_image(as_jpeg(kRealdata / file));
    CAPTURE(file);
    REQUIRE(r.j);
    CHECK((r.exit_code == 0 || r.exit_code == 1));
    if (!absolute(*r.j)) continue;
    ++identified;
    const json &got = (*r.j)["chart"]["largest_element"], &was = (*original.j)["chart"]["largest_element"];
    CHECK(got["group"] == was["group"]);
    CHECK(got["element"] == was["element"]);
    for (const std::string o : {"horizontal_bars", "vertical_bars"}) {
      CAPTURE(o);
      const json &l = (*r.j)["limits"][o], &l0 = (*original.j)["limits"][o];
      CHECK(l["resolved_any"] == l0["resolved_any"]);
      if (l0["resolved_any"] != true || l["resolved_any"] != true) continue;
      ++compared;
      CHECK(std::abs(element_index(l["group"], l["element"]) - element_index(l0["group"], l0["element"])) <= 1);
    }
  }
  MESSAGE("saved as JPEG (quality 85): " << identified << " of 7 identified as the original; " << compared
                                         << " limits compared");
  CHECK(identified == 7);
}

namespace {

// `image` turned by angle_deg about its centre, resampled (OpenImageIO's
// default filter), its first three channels at most, 8 bits: a chart set
// down askew. In the scratch folder, never in the repo.
fs::path turned_by(const fs::path& image, double angle_deg) {
  namespace oiio = OIIO;
  const oiio::ImageBuf in(image.string());
  const oiio::ImageBuf colour = oiio::ImageBufAlgo::channels(in, std::min(in.nchannels(), 3), {});
  const oiio::ImageBuf out = oiio::ImageBufAlgo::rotate(colour, static_cast<float>(angle_deg * M_PI / 180));
  const fs::path path = scratch_dir() / (image.stem().string() + "_askew" + std::to_string(int(angle_deg)) + ".png");
  REQUIRE_MESSAGE(out.write(path.string(), oiio::TypeDesc::UINT8), out.geterror());
  return path;
}

}  // namespace

// Set down askew (turned by 5, -8 or 12 deg and resampled), a labelled
// capture must never be identified differently from the original, should
// be identified, and its limits should stay within one element of the
// readings; nothing may be called resolved beyond them. (Askew by 5 or 8
// deg, dev_04's inner pair nested about no point, its group 7 went
// unpredicted and its V limit fell from G7E5 to G6E6 until a small
// pattern's own error of place was allowed: fit_nesting.)
constexpr int kMinAskewIdentified = 19;  // of 21 on 2026-12-03: dev_02 at 12 deg and dev_03 at -8 deg stay relative
constexpr int kMinAskewAgreeing = 36;    // of the 42 readings on 2026-12-03

TEST_CASE("real chart captures set down askew are never identified differently") {
  if (!fs::exists(kRealdata)) {
    MESSAGE("skipped: " << kRealdata.string() << " is absent (the real captures are never copied into the repo)");
    return;
  }
  std::map<std::string, json> by_orig;
  const json all = readings();
  for (const json& im : all["images"]) by_orig[im["orig"].get<std::string>()] = im;
  int tried = 0, identified = 0, readings_n = 0, agreeing = 0;
  std::string table;
  for (const std::string file : {"dev_01_orig.tif", "dev_02_orig.tif", "dev_03_orig.png", "dev_04_orig.png",
                                 "dev_05_orig.png", "dev_11_orig.png", "dev_14_orig.png"}) {
    const Run& original = measure(file);
    REQUIRE(original.j);
    REQUIRE(absolute(*original.j));
    const json& im = by_orig.at(file);
    for (const double angle_deg : {5.0, -8.0, 12.0}) {
      const Run& r = measure_image(turned_by(kRealdata / file, angle_deg));
      CAPTURE(file);
      CAPTURE(angle_deg);
      REQUIRE(r.j);
      CHECK((r.exit_code == 0 || r.exit_code == 1));
      ++tried;
      table += "  " + file + " turned " + std::to_string(int(angle_deg)) + " deg:";
      for (const char* o : {"horizontal_bars", "vertical_bars"}) {
        if (im[o].is_null()) continue;
        ++readings_n;
        const std::optional<int> d = limit_from_reading(*r.j, im, o);
        agreeing += d && std::abs(*d) <= 1;
        table += std::string(" ") + o[0] + (d ? (*d >= 0 ? " +" : " ") + std::to_string(*d) : std::string(" -"));
      }
      table += "\n";
      if (!absolute(*r.j)) continue;
      ++identified;
      const json &got = (*r.j)["chart"]["largest_element"], &was = (*original.j)["chart"]["largest_element"];
      CHECK(got["group"] == was["group"]);
      CHECK(got["element"] == was["element"]);
      check_resolved_within_reading(*r.j, im, file);
    }
  }
  MESSAGE("set down askew: " << identified << " of " << tried << " identified as the original; " << agreeing << " of "
                             << readings_n << " limits within one element of the reading (elements from it; - "
                             << "relative or none)\n"
                             << table);
  CHECK(tried == 21);
  CHECK(identified >= kMinAskewIdentified);
  CHECK(agreeing >= kMinAskewAgreeing);
}

// Real photographs that hold no chart, from another project (Debian's
// libleptonica-dev, installed with Tesseract: a portrait and an angiogram):
// chart mode must find nothing there, not bars in hair, fabric or vessels.
TEST_CASE("real photographs without a chart: no chart found, exit 2") {
  const fs::path docs = "/usr/share/doc/libleptonica-dev";
  int tried = 0;
  for (const char* name : {"dave-orig.png", "aneurisms8.jpg"}) {
    if (!fs::exists(docs / name)) continue;
    ++tried;
    CAPTURE(name);
    const Run& r = measure_image(docs / name);
    CHECK(r.exit_code == 2);
    REQUIRE(r.j);
    CHECK_FALSE((*r.j)["usable"].get<bool>());
    CHECK((*r.j)["problem"].get<std::string>().find("no USAF-1951 chart found") != std::string::npos);
  }
  if (tried == 0) MESSAGE("skipped: " << docs.string() << " holds none of the sample photographs");
  // A plot (Debian's nodejs docs, a ggplot figure): three of its strokes
  // pass for a single pattern filling the frame. Refused, and the message
  // says what was found, not only that it is clipped.
  const fs::path plot = "/usr/share/doc/nodejs/contributing/doc_img/scatter-plot.png";
  if (!fs::exists(plot)) {
    MESSAGE("skipped: " << plot.string() << " is absent");
    return;
  }
  const Run& r = measure_image(plot);
  CHECK(r.exit_code == 2);
  REQUIRE(r.j);
  CHECK_FALSE((*r.j)["usable"].get<bool>());
  const std::string problem = (*r.j)["problem"].get<std::string>();
  CHECK((problem.find("no USAF-1951 chart found") != std::string::npos ||
         problem.find("if the image shows no chart, it is not one") != std::string::npos));
}

