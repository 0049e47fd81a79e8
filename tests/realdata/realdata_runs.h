#pragma once
// The real-data suites' shared part (realdata_chart_test.cpp,
// realdata_copies_test.cpp): the captures in ../shared/realdata, measured
// by the CLI once per image and process, and the readings kept beside
// this file (readings.json; how they were made: READINGS.md).

#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

namespace tactres_realdata {

namespace fs = std::filesystem;
using nlohmann::json;

inline const fs::path kRealdata = fs::path(TACTRES_SOURCE_DIR) / ".." / "shared" / "realdata";

// True, and says so, when ../shared/realdata is absent: the suites then
// skip (the images are never copied into the repository).
bool realdata_absent();

// Series index of group g, element e (G0E1 = 0).
int element_index(int group, int element);

struct Run {
  int exit_code = -1;
  std::optional<json> j;  // the measurement JSON; none when absent or not parsed (NaN, inf)
};

// This process's scratch folder (the JSON files, and the copies of the
// captures), removed when the process ends.
const fs::path& scratch_dir();

// `tactres measure IMAGE --chart usaf1951`, run once per image (cached).
const Run& measure_image(const fs::path& image);
// A capture of ../shared/realdata by its file name.
const Run& measure(const std::string& file);

// readings.json.
json readings();

// The measurement's indices are absolute (the chart anchored).
bool absolute(const json& j);

// With absolute indices, no element of `j` called resolved more than one
// element beyond the reading `im` (an entry of readings.json; doctest
// CHECKs). Beyond the chain, elements whose own profiles show three maxima
// (READINGS.md, `three_maxima_beyond`) may be resolved on their own.
void check_resolved_within_reading(const json& j, const json& im, const std::string& file);

// How many elements the discrete limit of `j` in orientation `o` lies
// from the reading `im`'s; nullopt without a reading there, absolute
// indices, or anything resolved.
std::optional<int> limit_from_reading(const json& j, const json& im, const char* o);

// Where a copy's pixel was in its original's pixels ((0, 0) the centre of
// the top-left pixel).
struct Px {
  double x = 0, y = 0;
};
using PixelMap = std::function<Px(Px)>;

// A measurement's image width and height (its "input" block).
Px size_of(const json& j);

// A copy resized (OpenImageIO maps pixel areas: the edges stay the edges),
// or one of the same size (the identity).
PixelMap resized_back(const json& copy, const json& original);

// Each element the copy measured where its original measured one of the
// same orientation (the middle of its strip mapped back, within 1.5 of the
// original's bar widths: neighbours in a column stand 6.5 or more apart)
// carries the original's name (doctest CHECKs): an index one off would
// give it another element's frequency. Counted in `matched`; the copy must
// match some.
void check_named_alike(const json& copy, const json& original, const PixelMap& to_original, int& matched);

}  // namespace tactres_realdata
