// LabelReader on printed numbers cropped from real photographs of USAF-1951
// charts (../shared/realdata, see its README.md; never copied into the
// repository). Skips, saying so, when that folder is absent.
//
// The crops were placed by viewing each dev_NN.png (the 16-bit grey
// conversions) enlarged 2-4x with a 10 px grid; every crop holds one whole
// number with a few pixels of ground and no bar. The values are what the
// charts print there (tests/realdata/READINGS.md describes the layouts):
// - dev_11: a whole chart (groups 0-3), upright, dark ordinary sans-serif
//   numerals on a light ground; the group-1 element numbers lie in a
//   shadow band with salt speckle.
// - dev_14: groups 4-7, upright, dark numerals of the chart maker's own
//   blocky typeface (a "6" drawn like a "b", a "4" open at the top).
// - dev_04: groups 4-7 through a Miniscope, upright, light blocky numerals
//   on a dark ground, blurred.
// Tesseract's English model reads the sans-serif numerals; the blocky ones
// it reads only in part, so for those the test asks for the chart's
// orientation and the readings marked `must_read` (what this reader reads
// today), and reports the rest.
#include <doctest/doctest.h>

#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "orientation.h"
#include "tactres/camera/image_io.h"
#include "tactres/labels/label_reader.h"

using namespace tactres;

namespace {

namespace fs = std::filesystem;

const fs::path kRealdata = fs::path(TACTRES_SOURCE_DIR) / ".." / "shared" / "realdata";

struct LabelCrop {
  cv::Rect crop_px;  // in dev_NN.png pixels
  int value;         // the number printed there
  bool must_read;    // read correctly today (blocky typefaces: only some)
  const char* what;
};

struct ChartCrops {
  const char* file;
  std::vector<LabelCrop> labels;
};

const std::vector<ChartCrops>& chart_crops() {
  static const std::vector<ChartCrops> charts{
      {"dev_11.png",
       {{{370, 150, 70, 85}, 0, true, "group 0, above the column"},
        {{195, 270, 58, 82}, 2, true, "G0E2"},
        {{190, 395, 62, 80}, 3, true, "G0E3"},
        {{182, 502, 56, 88}, 4, true, "G0E4"},
        {{738, 212, 28, 54}, 1, true, "group 1, above the column"},
        {{833, 290, 24, 42}, 1, true, "G1E1, shadow band"},
        {{826, 362, 32, 44}, 2, true, "G1E2, shadow band"},
        {{820, 424, 38, 44}, 3, true, "G1E3, shadow band"},
        {{818, 480, 40, 44}, 4, true, "G1E4, shadow band"}}},
      {"dev_14.png",
       {{{50, 102, 42, 60}, 2, true, "G4E2"},
        {{50, 175, 42, 57}, 3, false, "G4E3"},
        {{50, 237, 42, 58}, 4, true, "G4E4"},
        {{50, 300, 42, 57}, 5, true, "G4E5"},
        {{50, 362, 42, 60}, 6, false, "G4E6 (a blocky 6)"},
        {{354, 61, 28, 37}, 5, true, "group 5, above the column"},
        {{408, 104, 26, 32}, 1, true, "G5E1"},
        {{408, 145, 26, 33}, 2, false, "G5E2"},
        {{408, 183, 26, 33}, 3, true, "G5E3"},
        {{408, 218, 26, 31}, 4, true, "G5E4"},
        {{408, 251, 26, 31}, 5, false, "G5E5"},
        {{408, 279, 26, 32}, 6, false, "G5E6 (a blocky 6)"}}},
      {"dev_04.png",
       {{{8, 143, 49, 54}, 2, true, "G4E2"},
        {{8, 255, 49, 54}, 3, true, "G4E3"},
        {{10, 352, 48, 60}, 4, true, "G4E4"},
        {{8, 442, 50, 60}, 5, false, "G4E5"},
        {{124, 50, 50, 62}, 4, true, "group 4, above the column"},
        {{433, 40, 56, 62}, 5, true, "group 5, above the column"}}},
  };
  return charts;
}

// Every label of one chart read in all orientations, each crop first turned
// by `o` (as if the whole chart were seen that way), then the vote.
struct ChartReading {
  std::vector<std::vector<NumberReading>> labels;
  std::optional<OrientationVote> vote;
};

ChartReading read_chart(LabelReader& reader, const cv::Mat& luminance, const ChartCrops& chart, LabelOrientation o) {
  ChartReading out;
  for (const LabelCrop& label : chart.labels)
    out.labels.push_back(reader.read_number_any_orientation(labels_detail::orient(luminance(label.crop_px), o)));
  out.vote = vote_orientation(out.labels);
  return out;
}

bool realdata_present() {
  if (fs::is_directory(kRealdata)) return true;
  MESSAGE("skipped: " << kRealdata.string() << " is absent (real captures are not in the repository)");
  return false;
}

}  // namespace

TEST_CASE("real chart labels read with the chart's orientation found") {
  if (!realdata_present()) return;
  const LabelReaderOrError created = LabelReader::create();
  REQUIRE_MESSAGE(created.reader, created.error);
  for (const ChartCrops& chart : chart_crops()) {
    const cv::Mat luminance = load_image(kRealdata / chart.file).luminance;
    const ChartReading upright = read_chart(*created.reader, luminance, chart, {});
    const std::string file = chart.file;
    CAPTURE(file);
    REQUIRE(upright.vote);
    CHECK(upright.vote->orientation == LabelOrientation{0, false});
    int read = 0;
    for (size_t i = 0; i < chart.labels.size(); ++i) {
      const LabelCrop& label = chart.labels[i];
      const NumberReading* r = reading_in(upright.labels[i], upright.vote->orientation);
      const bool right = r && r->value == label.value;
      read += right;
      const std::string what = label.what;
      CAPTURE(what);
      if (label.must_read) CHECK(right);
      if (!right)
        MESSAGE(chart.file << " " << label.what << ": read " << (r ? r->text : "nothing") << ", printed "
                           << label.value);
    }
    MESSAGE(chart.file << ": " << read << " of " << chart.labels.size() << " labels read upright");
  }
}

TEST_CASE("real sans-serif chart labels read turned and mirrored") {
  if (!realdata_present()) return;
  const LabelReaderOrError created = LabelReader::create();
  REQUIRE_MESSAGE(created.reader, created.error);
  const ChartCrops& chart = chart_crops().front();  // dev_11
  const cv::Mat luminance = load_image(kRealdata / chart.file).luminance;
  for (const LabelOrientation& o : all_label_orientations()) {
    const ChartReading seen = read_chart(*created.reader, luminance, chart, o);
    CAPTURE(to_string(o));
    REQUIRE(seen.vote);
    CHECK(seen.vote->orientation == o);
    for (size_t i = 0; i < chart.labels.size(); ++i) {
      const NumberReading* r = reading_in(seen.labels[i], o);
      const std::string what = chart.labels[i].what;
      CAPTURE(what);
      REQUIRE(r);
      CHECK(r->value == chart.labels[i].value);
    }
  }
}
