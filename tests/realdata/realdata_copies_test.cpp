// The labelled real captures (../shared/realdata) as other tools and
// other set-ups would hand them over: turned by 90 or 180 deg or mirrored
// (pixels moved), set down askew (turned and resampled), defocused, saved
// as JPEG, resized, with more noise. Each copy is made with OpenImageIO in
// the process's scratch folder, never in the repo, and must never be
// identified differently from its original, nor name any element it
// measures where the original measured one otherwise (check_named_alike:
// the JSON's center_px mapped back through the copy's pixel map); askew
// its limits are held to the readings; defocused, resized or noisier they
// may never rise more than one element; as JPEG they stay within one
// element of the original's.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <string>

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <doctest/doctest.h>

#include "realdata_runs.h"

using namespace tactres_realdata;

namespace {

// The labelled captures (anchored in the originals) the copies are made of.
const char* const kLabelled[] = {"dev_01_orig.tif", "dev_02_orig.tif", "dev_03_orig.png", "dev_04_orig.png",
                                 "dev_05_orig.png", "dev_11_orig.png", "dev_14_orig.png"};

// The original's measurement, anchored as the agreement test requires.
const json& anchored_original(const std::string& file) {
  const Run& original = measure(file);
  REQUIRE(original.j);
  REQUIRE(absolute(*original.j));
  return *original.j;
}

// A copy's measurement: it must exit 0 or 1 and write a JSON with no NaN.
const json& measured_copy(const fs::path& copy) {
  const Run& r = measure_image(copy);
  REQUIRE(r.j);
  CHECK((r.exit_code == 0 || r.exit_code == 1));
  return *r.j;
}

// One orientation in a table: " h +1" (elements from a reference), or
// " h " and `none` without a limit.
std::string table_entry(const std::string& orientation, std::optional<int> d, const char* none) {
  char text[32];
  if (d) std::snprintf(text, sizeof text, " %c %+d", orientation[0], *d);
  else std::snprintf(text, sizeof text, " %c %s", orientation[0], none);
  return text;
}

// A limit of `copy` against the original's, in elements (+: finer), for
// the table; nullopt when either resolves nothing in that orientation.
std::optional<int> limit_change(const json& copy, const json& original, const std::string& o) {
  const json &l = copy["limits"][o], &l0 = original["limits"][o];
  if (l["resolved_any"] != true || l0["resolved_any"] != true) return std::nullopt;
  return element_index(l["group"], l["element"]) - element_index(l0["group"], l0["element"]);
}

// The copy names its largest element found as the original would: the
// same element, or (when the copy finds a different one: dev_03 askew by
// 12 deg loses G4E2) the index its period says, 2^(1/6) per index from
// the original's largest. Periods as found: defocused by 13 px, dev_14's
// G4E1 reads 4.6 % long (0.39 of a step).
// A copy resized by `scale` has its periods scaled alike.
void check_identified_alike(const json& copy, const json& original, double scale = 1) {
  const json &got = copy["chart"]["largest_element"], &was = original["chart"]["largest_element"];
  const double steps = 6 * std::log2(scale * was["period_px"].get<double>() / got["period_px"].get<double>());
  CAPTURE(steps);
  CHECK(std::abs(steps - std::round(steps)) < 0.45);
  CHECK(element_index(got["group"], got["element"]) - element_index(was["group"], was["element"]) ==
        std::lround(steps));
}

// A copy's limits against its original's, appended to `table`: none may
// lie more than one element finer (resampling, blur and noise add no
// detail), nor more than `max_loss` coarser when given. Returns how many
// of the two orientations resolve anything in both.
int check_limits_against_original(const json& copy, const json& original, std::string& table,
                                  std::optional<int> max_loss = std::nullopt) {
  int resolved = 0;
  for (const std::string o : {"horizontal_bars", "vertical_bars"}) {
    CAPTURE(o);
    const std::optional<int> d = limit_change(copy, original, o);
    table += table_entry(o, d, "none");
    if (!d) continue;
    ++resolved;
    CHECK(*d <= 1);
    if (max_loss) CHECK(*d >= -*max_loss);
  }
  table += "\n";
  return resolved;
}

// What the copies of one kind came to, and their table.
struct CopyCounts {
  int tried = 0, identified = 0, resolved_any = 0;
  int matched = 0;  // elements matched to the original's by place (check_named_alike)
  std::string table;
};

// A measured copy of the labelled capture `file` (its row labelled
// `label`, if any): where it is identified, named as the original
// (check_identified_alike, periods scaled by `scale`) with limits as
// check_limits_against_original allows (`max_loss`).
void tally_copy(const std::string& file, const json& copy, const std::string& label, CopyCounts& counts,
                double scale = 1, std::optional<int> max_loss = std::nullopt) {
  const json& original = anchored_original(file);
  ++counts.tried;
  counts.table += "  " + file + (label.empty() ? "" : " " + label) + ":";
  if (!absolute(copy)) {
    counts.table += " relative\n";
    return;
  }
  ++counts.identified;
  check_identified_alike(copy, original, scale);
  check_named_alike(copy, original, resized_back(copy, original), counts.matched);
  counts.resolved_any += check_limits_against_original(copy, original, counts.table, max_loss);
}

// The copy at `path`, measured (exit 0 or 1), then tallied (tally_copy).
void check_copy(const std::string& file, const fs::path& path, const std::string& label, CopyCounts& counts,
                double scale = 1, std::optional<int> max_loss = std::nullopt) {
  tally_copy(file, measured_copy(path), label, counts, scale, max_loss);
}

}  // namespace

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

// Where a pixel of a copy `transformed` made was in the original (`size`:
// its width and height): rotate90 turns clockwise on screen, flop mirrors
// left-right.
PixelMap transformed_back(const std::string& how, Px size) {
  if (how == "turned_90") return [=](Px p) { return Px{p.y, size.y - 1 - p.x}; };
  if (how == "turned_180") return [=](Px p) { return Px{size.x - 1 - p.x, size.y - 1 - p.y}; };
  REQUIRE(how == "mirrored");
  return [=](Px p) { return Px{size.x - 1 - p.x, p.y}; };
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
  if (realdata_absent()) return;
  int compared = 0, identified = 0, matched = 0;
  std::string relative;
  for (const std::string file : {"dev_01_orig.tif", "dev_02_orig.tif", "dev_03_orig.png", "dev_04_orig.png",
                                 "dev_05_orig.png", "dev_14_orig.png"}) {
    const json& original = anchored_original(file);
    const json& largest = original["chart"]["largest_element"];
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
      check_named_alike(*r.j, original, transformed_back(how, size_of(original)), matched);
      const json& got = (*r.j)["chart"]["largest_element"];
      CHECK(got["group"] == largest["group"]);
      CHECK(got["element"] == largest["element"]);
      // The same element: its period as found (pixels moved only).
      CHECK(got["period_px"].get<double>() == doctest::Approx(largest["period_px"].get<double>()).epsilon(0.05));
    }
  }
  MESSAGE("turned or mirrored: " << identified << " of " << compared << " identified as the original, " << matched
                                 << " elements named as the original's at their place; relative:"
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
  if (realdata_absent()) return;
  int compared = 0, identified = 0, matched = 0;
  for (const std::string file : kLabelled) {
    const json& original = anchored_original(file);
    CAPTURE(file);
    const json& copy = measured_copy(as_jpeg(kRealdata / file));
    if (!absolute(copy)) continue;
    ++identified;
    check_named_alike(copy, original, resized_back(copy, original), matched);
    const json &got = copy["chart"]["largest_element"], &was = original["chart"]["largest_element"];
    CHECK(got["group"] == was["group"]);
    CHECK(got["element"] == was["element"]);
    for (const std::string o : {"horizontal_bars", "vertical_bars"}) {
      CAPTURE(o);
      const json &l = copy["limits"][o], &l0 = original["limits"][o];
      CHECK(l["resolved_any"] == l0["resolved_any"]);
      if (l0["resolved_any"] != true || l["resolved_any"] != true) continue;
      ++compared;
      CHECK(std::abs(element_index(l["group"], l["element"]) - element_index(l0["group"], l0["element"])) <= 1);
    }
  }
  MESSAGE("saved as JPEG (quality 85): " << identified << " of 7 identified as the original, " << matched
                                         << " elements named as the original's at their place; " << compared
                                         << " limits compared");
  CHECK(identified == 7);
}

namespace {

// `image`'s first three channels at most, as `change` makes them of that
// (and the input's spec), written as an 8-bit PNG named after `image` and
// `suffix` in the scratch folder, never in the repo.
template <class Change>
fs::path changed_copy(const fs::path& image, const std::string& suffix, Change change) {
  namespace oiio = OIIO;
  const oiio::ImageBuf in(image.string());
  const oiio::ImageBuf out = change(oiio::ImageBufAlgo::channels(in, std::min(in.nchannels(), 3), {}), in.spec());
  const fs::path path = scratch_dir() / (image.stem().string() + suffix + ".png");
  REQUIRE_MESSAGE(out.write(path.string(), oiio::TypeDesc::UINT8), out.geterror());
  return path;
}

// `image` turned by angle_deg about its centre, resampled (OpenImageIO's
// default filter): a chart set down askew.
fs::path turned_by(const fs::path& image, double angle_deg) {
  return changed_copy(image, "_askew" + std::to_string(int(angle_deg)), [&](const OIIO::ImageBuf& b, const auto&) {
    return OIIO::ImageBufAlgo::rotate(b, static_cast<float>(angle_deg * M_PI / 180));
  });
}

// Where a pixel of a copy `turned_by` made was in the original (`size`:
// the width and height of both): ImageBufAlgo::rotate turns clockwise on
// screen about the middle of the image, keeping its size.
PixelMap turned_by_back(double angle_deg, Px size) {
  const double c = std::cos(angle_deg * M_PI / 180), s = std::sin(angle_deg * M_PI / 180);
  const Px mid{0.5 * size.x - 0.5, 0.5 * size.y - 0.5};
  return [=](Px p) {
    const double dx = p.x - mid.x, dy = p.y - mid.y;
    return Px{mid.x + c * dx + s * dy, mid.y - s * dx + c * dy};
  };
}

}  // namespace

// Set down askew (turned by 5, -8 or 12 deg and resampled), a labelled
// capture must never be identified differently from the original, should
// be identified, and its limits should stay within one element of the
// readings; no limit may lie more than one element beyond them. (Askew by
// 5 or 8 deg, dev_04's inner pair nested about no point, its group 7 went
// unpredicted and its V limit fell from G7E5 to G6E6 until a small
// pattern's own error of place was allowed: fit_nesting.) Single elements
// past the chain are not held to the readings here, as they are in the
// originals: 21 copies of 20-60 elements each, judged at 2 sigma, show
// a few by chance (dev_11 askew by 5 deg: G3E3 H, m 0.21 +- 0.09, three
// past the reading, between unresolved neighbours).
constexpr int kMinAskewIdentified = 19;  // of 21 on 2026-12-03: dev_02 at 12 deg and dev_03 at -8 deg stay relative
constexpr int kMinAskewAgreeing = 37;    // of the 42 readings on 2026-12-03 (session 33)

TEST_CASE("real chart captures set down askew are never identified differently") {
  if (realdata_absent()) return;
  std::map<std::string, json> by_orig;
  const json all = readings();
  for (const json& im : all["images"]) by_orig[im["orig"].get<std::string>()] = im;
  int tried = 0, identified = 0, readings_n = 0, agreeing = 0, matched = 0;
  std::string table;
  for (const std::string file : kLabelled) {
    const json& original = anchored_original(file);
    const json& im = by_orig.at(file);
    for (const double angle_deg : {5.0, -8.0, 12.0}) {
      CAPTURE(file);
      CAPTURE(angle_deg);
      const json& copy = measured_copy(turned_by(kRealdata / file, angle_deg));
      ++tried;
      table += "  " + file + " turned " + std::to_string(int(angle_deg)) + " deg:";
      for (const char* o : {"horizontal_bars", "vertical_bars"}) {
        if (im[o].is_null()) continue;
        ++readings_n;
        const std::optional<int> d = limit_from_reading(copy, im, o);  // none unless absolute
        agreeing += d && std::abs(*d) <= 1;
        if (d) CHECK(*d <= 1);
        table += table_entry(o, d, "-");
      }
      table += "\n";
      if (!absolute(copy)) continue;
      ++identified;
      check_identified_alike(copy, original);
      check_named_alike(copy, original, turned_by_back(angle_deg, size_of(original)), matched);
    }
  }
  MESSAGE("set down askew: " << identified << " of " << tried << " identified as the original, " << matched
                             << " elements named as the original's at their place; " << agreeing << " of "
                             << readings_n << " limits within one element of the reading (elements from it; - "
                             << "relative or none)\n"
                             << table);
  CHECK(tried == 21);
  CHECK(identified >= kMinAskewIdentified);
  CHECK(agreeing >= kMinAskewAgreeing);
}

namespace {

// `image` defocused: convolved with a Gaussian kernel `width_px` wide
// (OpenImageIO's make_kernel).
fs::path defocused(const fs::path& image, int width_px) {
  return changed_copy(image, "_blur" + std::to_string(width_px), [&](const OIIO::ImageBuf& b, const auto&) {
    const OIIO::ImageBuf kernel = OIIO::ImageBufAlgo::make_kernel("gaussian", float(width_px), float(width_px));
    return OIIO::ImageBufAlgo::convolve(b, kernel);
  });
}

}  // namespace

// Defocused (Gaussian kernels 7 and 13 px wide), a labelled capture must
// never be identified differently, and where identified, no limit may
// rise more than one element above the original's: blur never sharpens;
// and each orientation must still resolve its coarse elements. (dev_01's
// copies stay relative: the blur closes its small group numbers. One of
// them read H "nothing resolved" while G6E1-G7E3 H showed bars, until a
// coarse element looked past finer ones judged damaged: grade_damaged.)
constexpr int kMinDefocusedIdentified = 12;  // of 14 on 2026-12-03: dev_01's two copies stay relative

TEST_CASE("real chart captures defocused are never identified differently, nor read finer") {
  if (realdata_absent()) return;
  CopyCounts c;
  for (const std::string file : kLabelled)
    for (const int width_px : {7, 13}) {
      CAPTURE(file);
      CAPTURE(width_px);
      check_copy(file, defocused(kRealdata / file, width_px), "blurred " + std::to_string(width_px) + " px", c);
    }
  MESSAGE("defocused: " << c.identified << " of " << c.tried << " identified as the original, " << c.matched
                        << " elements named as the original's at their place; " << c.resolved_any
                        << " limits resolved (elements from the original's)\n"
                        << c.table);
  CHECK(c.tried == 14);
  CHECK(c.identified >= kMinDefocusedIdentified);
  CHECK(c.resolved_any == 2 * c.identified);  // coarse elements survive the blur
}

namespace {

// `image` resized by `scale` (OpenImageIO's default filter for it): the
// chart seen by a camera with more or fewer pixels.
fs::path resized(const fs::path& image, double scale) {
  return changed_copy(image, "_x" + std::to_string(int(100 * scale)), [&](const OIIO::ImageBuf& b, const auto& spec) {
    const OIIO::ROI size(0, int(std::lround(scale * spec.width)), 0, int(std::lround(scale * spec.height)), 0, 1, 0,
                         b.nchannels());
    return OIIO::ImageBufAlgo::resize(b, "", 0, size);
  });
}

}  // namespace

// Resized by 0.8 or 1.25 (resampled), a labelled capture must never be
// identified differently (its periods scaled alike), should be identified,
// and no limit may lie more than one element finer than the original's:
// resampling adds no detail. (dev_14's 1.25x copy read G6E6 both ways,
// against the original's G7E2, until a misfit whose gaps both dip was read
// from its dips: G7E1 V at 1.9 px per bar had been graded aliased.)
constexpr int kMinResizedIdentified = 14;  // of 14 on 2026-12-03

TEST_CASE("real chart captures resized are never identified differently, nor read finer") {
  if (realdata_absent()) return;
  CopyCounts c;
  for (const std::string file : kLabelled)
    for (const double scale : {0.8, 1.25}) {
      CAPTURE(file);
      CAPTURE(scale);
      // Enlarged, the copy loses at most one element to the filter's blur.
      check_copy(file, resized(kRealdata / file, scale), scale < 1 ? "x0.8" : "x1.25", c, scale,
                 scale > 1 ? std::optional<int>(1) : std::nullopt);
    }
  MESSAGE("resized: " << c.identified << " of " << c.tried << " identified as the original, " << c.matched
                      << " elements named as the original's at their place (limits in elements from the "
                      << "original's)\n"
                      << c.table);
  CHECK(c.tried == 14);
  CHECK(c.identified >= kMinResizedIdentified);
  CHECK(c.resolved_any == 2 * c.identified);
}

namespace {

// `image` with Gaussian noise of `sd` of full scale added to every pixel
// (the same in each channel), clipped at 0 and 255 as a camera's would be.
fs::path noisier(const fs::path& image, float sd) {
  return changed_copy(image, "_noise" + std::to_string(int(100 * sd)), [&](OIIO::ImageBuf b, const auto&) {
    REQUIRE_MESSAGE(OIIO::ImageBufAlgo::noise(b, "gaussian", 0.0f, sd, true, 7), b.geterror());
    return b;
  });
}

}  // namespace

// With noise of 2 % of full scale added (8 bits, clipped at 0 and 255), a
// labelled capture must never be identified differently, nor read more
// than one element finer than the original; where it cannot be measured
// (exit 2) the problem says why. (The dark ground of the negative
// fibre-bundle frame dev_02 then clips at black in every bin of every
// coarse pattern, a quarter of their pixels: read past the clipping
// (profiles/censored_level.h) they give the level step, where as bounds
// they gave none and the copy was refused until 2026-12-04. dev_14's
// coarse patterns clip too, two of them at black only, which give the
// step: chart_level_steps. The numbers of dev_01, under its honeycomb,
// and of dev_02 no longer read: relative.)
constexpr int kMinNoisierMeasured = 7;     // of 7 on 2026-12-04 (6 before)
constexpr int kMinNoisierIdentified = 5;   // of 7 on 2026-12-03

TEST_CASE("real chart captures with added noise are never identified differently, nor read finer") {
  if (realdata_absent()) return;
  int unusable = 0;
  CopyCounts c;  // of the measured ones
  for (const std::string file : kLabelled) {
    CAPTURE(file);
    anchored_original(file);  // measured first, as every copy's original
    const Run& r = measure_image(noisier(kRealdata / file, 0.02f));
    REQUIRE(r.j);
    const json& copy = *r.j;
    CHECK((r.exit_code == 0 || r.exit_code == 1 || r.exit_code == 2));
    if (r.exit_code == 2) {
      ++unusable;
      CHECK(copy["problem"].get<std::string>().size() > 20);
      c.table += "  " + file + ": unusable: " + copy["problem"].get<std::string>().substr(0, 60) + "...\n";
      continue;
    }
    tally_copy(file, copy, "", c);
  }
  MESSAGE("noisier (2 % of full scale): " << c.tried << " of " << c.tried + unusable << " measured, " << c.identified
                                          << " identified as the original, " << c.matched
                                          << " elements named as the original's at their place (limits in elements "
                                          << "from the original's)\n"
                                          << c.table);
  CHECK(c.tried >= kMinNoisierMeasured);
  CHECK(c.identified >= kMinNoisierIdentified);
  CHECK(c.resolved_any == 2 * c.identified);
}
