// LabelReader on numbers rendered in real fonts (DejaVu Sans, Liberation
// Sans) through FreeType, seen by a camera (blur, noise, both polarities,
// all eight orientations), and on what must not read as a number.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <omp.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "orientation.h"
#include "tactres/labels/label_reader.h"
#include "test_glyphs.h"

using namespace tactres;
using namespace tactres::labels_test;

namespace {

// Tesseract's LSTM opens OpenMP parallel regions whose thread start-up
// costs 3-5x the work on label-sized images (label_reader.h, "Cost"). This
// test executable makes every region inactive, process-wide, at start-up;
// the library itself never touches that global setting.
[[maybe_unused]] const bool serial_openmp = (omp_set_max_active_levels(0), true);

// One engine for the whole test executable: initialisation is the slow part.
LabelReader* shared_reader() {
  static const LabelReaderOrError created = LabelReader::create();
  if (!created.reader) MESSAGE(created.error);
  return created.reader.get();
}

// The ink's box in the patch as the camera sees it.
cv::Rect ink_box(const cv::Mat& coverage, LabelOrientation o) {
  std::vector<cv::Point> ink;
  cv::findNonZero(labels_detail::orient(coverage, o) > 0.5, ink);
  return cv::boundingRect(ink);
}

// The reading's box covers the ink and not much more.
bool box_fits(const cv::Rect& box, const cv::Rect& ink) {
  return (box & ink).area() >= 0.8 * ink.area() && box.area() <= 2.5 * ink.area();
}

CameraLook look_for(int index, bool light_ink, LabelOrientation o) {
  CameraLook look;
  if (light_ink) std::swap(look.ground, look.ink);
  look.blur_sigma_px = 0.5 + 0.1 * (index % 4);
  look.noise_sigma = 0.02;
  look.orientation = o;
  look.seed = static_cast<std::uint64_t>(index) + 1;
  return look;
}

// A USAF triplet (or fewer bars): bars w wide, 5w long, w apart.
cv::Mat bars_patch(int bars, int w, bool light_ink, bool vertical, std::uint64_t seed) {
  cv::Mat coverage = cv::Mat::zeros(5 * w + 4 * w, (2 * bars - 1) * w + 4 * w, CV_32F);
  for (int b = 0; b < bars; ++b) coverage(cv::Rect(2 * w + 2 * b * w, 2 * w, w, 5 * w)).setTo(1.0);
  CameraLook look = look_for(static_cast<int>(seed), light_ink, {vertical ? 0 : 90, false});
  look.seed = seed;
  return camera_patch(coverage, look);
}

}  // namespace

TEST_CASE("a reader is created from Debian's tessdata") {
  REQUIRE(shared_reader() != nullptr);
  CHECK(shared_reader()->options().min_confidence == doctest::Approx(60));
}

TEST_CASE("a missing model is reported as data naming the package and the variable") {
  LabelReaderOptions options;
  options.tessdata_dir = "/nonexistent/tessdata";
  const LabelReaderOrError created = LabelReader::create(options);
  CHECK(created.reader == nullptr);
  CHECK(created.error.find("/nonexistent/tessdata/eng.traineddata") != std::string::npos);
  CHECK(created.error.find("tesseract-ocr-eng") != std::string::npos);
  CHECK(created.error.find("TESSDATA_PREFIX") != std::string::npos);
  options = {};
  options.min_confidence = 120;
  CHECK_THROWS_AS(LabelReader::create(options), std::invalid_argument);
}

TEST_CASE("orientations turn counter-clockwise on screen after mirroring and invert exactly") {
  // 3 wide, 2 high, every pixel different.
  const cv::Mat m = (cv::Mat_<uchar>(2, 3) << 1, 2, 3, 4, 5, 6);
  const cv::Mat ccw = labels_detail::orient(m, {90, false});
  CHECK(ccw.size() == cv::Size(2, 3));
  CHECK(ccw.at<uchar>(0, 0) == 3);  // the top-right pixel comes to the top-left
  const cv::Mat mirrored_ccw = labels_detail::orient(m, {90, true});
  CHECK(mirrored_ccw.at<uchar>(0, 0) == 1);  // mirrored first: the top-left went right
  for (const LabelOrientation& o : all_label_orientations()) {
    const cv::Mat seen = labels_detail::orient(m, o);
    CHECK(cv::norm(labels_detail::make_upright(seen, o), m, cv::NORM_INF) == 0);
    for (int y = 0; y < m.rows; ++y)
      for (int x = 0; x < m.cols; ++x) {
        const cv::Rect b = labels_detail::oriented_box({x, y, 1, 1}, m.size(), o);
        REQUIRE(b.area() == 1);
        CHECK(seen.at<uchar>(b.y, b.x) == m.at<uchar>(y, x));
      }
  }
}

TEST_CASE("upright numbers -2 to 7 read in two fonts, both polarities, 10 to 20 px") {
  LabelReader* reader = shared_reader();
  REQUIRE(reader);
  int index = 0, read = 0;
  for (const TestFont& font : test_fonts())
    for (bool light : {false, true})
      for (int value = -2; value <= 7; ++value)
        for (double height_px : {10.0, 13.0, 16.0, 20.0}) {
          const cv::Mat coverage = render_text(font, std::to_string(value), height_px, 3);
          const cv::Mat patch = camera_patch(coverage, look_for(index++, light, {}));
          // The caller may know the polarity, or leave it to the reader.
          const Ink ink = index % 2 ? Ink::automatic : (light ? Ink::light : Ink::dark);
          const std::optional<NumberReading> r = reader->read_number(patch, ink);
          CAPTURE(font.name);
          CAPTURE(light);
          CAPTURE(value);
          CAPTURE(height_px);
          REQUIRE(r);
          CHECK(r->value == value);
          CHECK(r->confidence >= reader->options().min_confidence);
          CHECK_MESSAGE(box_fits(r->box_px, ink_box(coverage, {})),
                        "box " << r->box_px << ", ink " << ink_box(coverage, {}));
          read += r->value == value;
        }
  CHECK(read == index);
}

TEST_CASE("in every orientation each label has its true reading and a chart's labels vote for the orientation") {
  LabelReader* reader = shared_reader();
  REQUIRE(reader);
  int index = 0;
  for (const TestFont& font : test_fonts())
    for (bool light : {false, true})
      for (const LabelOrientation& o : all_label_orientations()) {
        CAPTURE(font.name);
        CAPTURE(light);
        CAPTURE(to_string(o));
        std::vector<std::vector<NumberReading>> chart;
        for (int value = -2; value <= 7; ++value, ++index) {
          const double height_px = 10 + (3 * index) % 11;  // 10..20 px over the labels
          const cv::Mat coverage = render_text(font, std::to_string(value), height_px, 3);
          chart.push_back(reader->read_number_any_orientation(camera_patch(coverage, look_for(index, light, o))));
          const NumberReading* truth = reading_in(chart.back(), o);
          CAPTURE(value);
          CAPTURE(height_px);
          REQUIRE(truth);
          CHECK(truth->value == value);
          CHECK(box_fits(truth->box_px, ink_box(coverage, o)));
        }
        const std::optional<OrientationVote> vote = vote_orientation(chart);
        REQUIRE(vote);
        CHECK(vote->orientation == o);
        CHECK(vote->labels_read == 10);
        CHECK(vote->runner_up_score < vote->score);
        for (size_t i = 0; i < chart.size(); ++i) CHECK(reading_in(chart[i], vote->orientation)->value == int(i) - 2);
      }
}

TEST_CASE("a USAF triplet, two bars, noise and flat patches are not read as a number") {
  LabelReader* reader = shared_reader();
  REQUIRE(reader);
  std::uint64_t seed = 1;
  for (int w : {2, 3, 4, 6})
    for (bool light : {false, true})
      for (bool vertical : {false, true})
        for (int bars : {2, 3}) {
          CAPTURE(w);
          CAPTURE(bars);
          CHECK(reader->read_number_any_orientation(bars_patch(bars, w, light, vertical, seed++)).empty());
        }
  cv::RNG rng(7);
  for (int k = 0; k < 40; ++k) {
    const int size_px = 24 + 6 * (k % 5);
    cv::Mat noise(size_px, size_px, CV_32F);
    if (k % 2)
      rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
    else
      rng.fill(noise, cv::RNG::NORMAL, 0.5, 0.2);
    const double blur_sigma_px = 0.5 * (k % 10);
    if (blur_sigma_px > 0) cv::GaussianBlur(noise, noise, cv::Size(), blur_sigma_px);
    CAPTURE(k);
    CAPTURE(blur_sigma_px);
    CHECK(reader->read_number_any_orientation(noise).empty());
  }
  CHECK(reader->read_number_any_orientation(cv::Mat(30, 30, CV_32F, cv::Scalar(0.5))).empty());
  CHECK(!reader->read_number(cv::Mat(30, 30, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()))));
  CHECK_THROWS_AS(reader->read_number(cv::Mat()), std::invalid_argument);
  CHECK_THROWS_AS(reader->read_number(cv::Mat(20, 20, CV_8UC3)), std::invalid_argument);
}

TEST_CASE("the orientation vote sums each orientation's confidence over the labels") {
  const auto reading = [](int value, double confidence, LabelOrientation o) {
    NumberReading r;
    r.value = value;
    r.confidence = confidence;
    r.orientation = o;
    return r;
  };
  // A 6 reads as a 9 turned over, a little more confidently; the 4 and the
  // 7 settle it.
  const std::vector<std::vector<NumberReading>> labels{
      {reading(9, 97, {180, false}), reading(6, 96, {0, false})},
      {reading(4, 95, {0, false})},
      {reading(7, 90, {0, false}), reading(1, 70, {90, true})},
      {},
  };
  const std::optional<OrientationVote> vote = vote_orientation(labels);
  REQUIRE(vote);
  CHECK(vote->orientation == LabelOrientation{0, false});
  CHECK(vote->score == doctest::Approx(96 + 95 + 90));
  CHECK(vote->runner_up_score == doctest::Approx(97));
  CHECK(vote->labels_read == 3);
  CHECK(reading_in(labels[0], vote->orientation)->value == 6);
  CHECK(reading_in(labels[1], {90, false}) == nullptr);
  CHECK(!vote_orientation({{}, {}}));
}

TEST_CASE("reopened counters read blurred numerals that Otsu fills in, and no wrong digit, nor noise") {
  // 30 px digits under Gaussian blur of 3-3.5 px (a tenth of their height
  // and more: dev_01's group numbers through a fibre bundle, smoothed): at
  // Otsu's threshold the counters of 4, 6, 8 and 9 fill in and the reader
  // refuses the blob; reopened, they read. (At 4 px the reader misreads
  // either way: a 0 reads as an 8 as it stands, an 8 as a 6 reopened.)
  LabelReader* reader = shared_reader();
  REQUIRE(reader);
  int kept = 0, reopened = 0;
  std::uint64_t seed = 1;
  for (const TestFont& font : test_fonts())
    for (const int digit : {0, 4, 6, 8, 9})
      for (const double blur_px : {3.0, 3.5}) {
        CameraLook look;
        look.blur_sigma_px = blur_px;
        look.seed = seed++;
        const cv::Mat patch = camera_patch(render_text(font, std::to_string(digit), 30, 12), look);
        const std::optional<NumberReading> k = reader->read_number(patch, Ink::dark, Counters::keep);
        const std::optional<NumberReading> r = reader->read_number(patch, Ink::dark, Counters::reopen);
        CAPTURE(font.name);
        CAPTURE(digit);
        CAPTURE(blur_px);
        if (k) CHECK(k->value == digit);
        if (r) CHECK(r->value == digit);
        kept += k.has_value();
        reopened += r.has_value();
      }
  MESSAGE("blurred numerals read: " << kept << " of 20 as they stand, " << reopened << " reopened");
  CHECK(reopened >= kept + 4);
  // Noise and texture stay unread, reopened or not.
  cv::RNG rng(11);
  for (int k = 0; k < 40; ++k) {
    cv::Mat noise(24 + 6 * (k % 5), 24 + 6 * (k % 5), CV_32F);
    rng.fill(noise, cv::RNG::NORMAL, 0.5, 0.2);
    cv::GaussianBlur(noise, noise, cv::Size(), 0.5 + 0.5 * (k % 8));
    CAPTURE(k);
    CHECK(!reader->read_number(noise, Ink::automatic, Counters::reopen));
  }
}

TEST_CASE("glyph_box: the ink read_number would read, whole or cut by the patch's edge") {
  LabelReader* reader = shared_reader();
  REQUIRE(reader);
  const labels_test::TestFont& font = labels_test::test_fonts().front();
  const cv::Mat whole = labels_test::camera_patch(labels_test::render_text(font, "4", 30, 12), {});
  const std::optional<cv::Rect> box = reader->glyph_box(whole);
  REQUIRE(box);
  // The digit, 30 px tall, inside the 12 px margin.
  CHECK(box->height == doctest::Approx(30).epsilon(0.15));
  CHECK(box->y > 0);
  CHECK(box->y + box->height < whole.rows);
  const std::optional<NumberReading> read = reader->read_number(whole);
  REQUIRE(read);
  CHECK(read->box_px == *box);
  // Its top 18 px cut off (the margin and a fifth of the digit): the box
  // runs to the top edge, and keeps the rest of the digit's height.
  const cv::Mat cut = whole.rowRange(18, whole.rows);
  const std::optional<cv::Rect> cut_box = reader->glyph_box(cut);
  REQUIRE(cut_box);
  CHECK(cut_box->y == 0);
  CHECK(cut_box->height == doctest::Approx(box->y + box->height - 18).epsilon(0.1));
  // No ink that stands out: nothing.
  CHECK_FALSE(reader->glyph_box(cv::Mat(30, 30, CV_32F, cv::Scalar(0.5))));
}
