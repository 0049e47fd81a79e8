// find_label_boxes on a small synthetic chart: USAF triplets beside printed
// numbers in a real font, turned and mirrored, in both polarities; and the
// boxes it finds read back through LabelReader.
#include <doctest/doctest.h>

#include <algorithm>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "ink.h"
#include "orientation.h"
#include "tactres/labels/label_boxes.h"
#include "tactres/labels/label_reader.h"
#include "test_glyphs.h"

using namespace tactres;
using namespace tactres::labels_test;

namespace {

struct Scene {
  cv::Mat coverage;              // CV_32F ink coverage, upright
  std::vector<cv::Rect> labels;  // each number's ink box, upright
  std::vector<int> values;
  std::vector<cv::Rect> bars;    // each triplet's ink box, upright
};

void add_label(Scene& s, const std::string& text, cv::Point at, double height_px) {
  const cv::Mat glyphs = render_text(test_fonts().front(), text, height_px, 0);
  const cv::Rect where(at, glyphs.size());
  cv::Mat target = s.coverage(where);
  cv::max(target, glyphs, target);
  s.labels.push_back(where);
  s.values.push_back(std::stoi(text));
}

// Three bars w wide and 5w long, w apart; `along_x`: long side along x.
void add_triplet(Scene& s, cv::Point at, int w, bool along_x) {
  for (int b = 0; b < 3; ++b) {
    const cv::Rect bar =
        along_x ? cv::Rect(at.x, at.y + 2 * b * w, 5 * w, w) : cv::Rect(at.x + 2 * b * w, at.y, w, 5 * w);
    s.coverage(bar).setTo(1.0);
  }
  s.bars.push_back(cv::Rect(at.x, at.y, 5 * w, 5 * w));  // square either way
}

// Like a group column of a chart: triplets with their element numbers, a
// group number with a minus sign, and a two-digit number.
Scene chart_scene() {
  Scene s;
  s.coverage = cv::Mat::zeros(150, 190, CV_32F);
  add_triplet(s, {20, 20}, 4, true);
  add_triplet(s, {50, 20}, 4, false);
  add_label(s, "2", {82, 22}, 16);
  add_triplet(s, {20, 70}, 3, true);
  add_triplet(s, {42, 70}, 3, false);
  add_label(s, "5", {70, 69}, 14);
  add_label(s, "-1", {120, 20}, 18);
  add_label(s, "12", {120, 100}, 15);
  return s;
}

}  // namespace

TEST_CASE("label boxes hold the numbers and not the bars in every orientation and polarity") {
  const Scene s = chart_scene();
  static const LabelReaderOrError created = LabelReader::create();
  REQUIRE(created.reader);
  int seed = 1;
  for (bool light : {false, true})
    for (const LabelOrientation& o : all_label_orientations()) {
      CAPTURE(light);
      CAPTURE(to_string(o));
      CameraLook look;
      if (light) std::swap(look.ground, look.ink);
      look.orientation = o;
      look.seed = static_cast<std::uint64_t>(seed++);
      const cv::Mat image = camera_patch(s.coverage, look);
      LabelBoxSearch search;
      search.min_char_height_px = 10;
      search.max_char_height_px = 24;
      search.ink = light ? Ink::light : Ink::dark;
      const std::vector<cv::Rect> boxes = find_label_boxes(image, search);
      CHECK(boxes.size() == s.labels.size());
      for (const cv::Rect& bars : s.bars) {
        const cv::Rect seen = labels_detail::oriented_box(bars, s.coverage.size(), o);
        for (const cv::Rect& b : boxes) CHECK((b & seen).area() < 0.1 * seen.area());
      }
      std::vector<std::vector<NumberReading>> readings(s.labels.size());
      for (size_t i = 0; i < s.labels.size(); ++i) {
        const cv::Rect seen = labels_detail::oriented_box(s.labels[i], s.coverage.size(), o);
        const auto holder =
            std::find_if(boxes.begin(), boxes.end(), [&](const cv::Rect& b) { return (b & seen) == seen; });
        CAPTURE(s.values[i]);
        if (holder == boxes.end()) MESSAGE("no box holds the label at " << seen);
        REQUIRE(holder != boxes.end());
        readings[i] = created.reader->read_number_any_orientation(image(*holder), search.ink);
      }
      const std::optional<OrientationVote> vote = vote_orientation(readings);
      REQUIRE(vote);
      CHECK(vote->orientation == o);
      for (size_t i = 0; i < s.labels.size(); ++i) {
        const NumberReading* r = reading_in(readings[i], o);
        REQUIRE(r);
        CHECK(r->value == s.values[i]);
      }
    }
}

TEST_CASE("label boxes stay inside the search rectangle and the character heights asked for") {
  const Scene s = chart_scene();
  const cv::Mat image = camera_patch(s.coverage, CameraLook{});
  LabelBoxSearch search;
  search.min_char_height_px = 10;
  search.max_char_height_px = 24;
  search.search_px = cv::Rect(0, 0, 110, 150);  // the two triplet pairs and their element numbers
  const std::vector<cv::Rect> left = find_label_boxes(image, search);
  REQUIRE(left.size() == 2);
  CHECK((left[0] & s.labels[0]) == s.labels[0]);  // "2" (top to bottom)
  CHECK((left[1] & s.labels[1]) == s.labels[1]);  // "5"
  search.search_px = {};
  search.min_char_height_px = 30;  // nothing printed is that tall
  search.max_char_height_px = 60;
  CHECK(find_label_boxes(image, search).empty());
  search.ink = Ink::automatic;
  CHECK_THROWS_AS(find_label_boxes(image, search), std::invalid_argument);
  search.ink = Ink::dark;
  search.min_char_height_px = 70;  // above the maximum
  CHECK_THROWS_AS(find_label_boxes(image, search), std::invalid_argument);
}

// The local darkest value behind the ink threshold: beyond 32 px it is
// taken on tiles, and must stay between the erosions by the window + 2
// tiles and the window - 4 tiles (ink.h), yet follow the true one closely.
// Odd image sizes and windows whose half is no whole number of tiles, and
// regions about one window wide, are where a tile spacing taken for the
// true one misses the bound.
TEST_CASE("the tiled local darkest value lies within the erosions it stands for") {
  cv::RNG rng(11);
  auto smooth_field = [&](cv::Size size) {
    cv::Mat g(size, CV_32F);
    rng.fill(g, cv::RNG::UNIFORM, 0.0, 1.0);
    cv::GaussianBlur(g, g, {0, 0}, 6);
    for (int k = 0; k < size.area() / 15000 + 2; ++k)  // dark specks, the extremes an erosion carries
      cv::circle(g, {rng.uniform(0, g.cols), rng.uniform(0, g.rows)}, 2, cv::Scalar(rng.uniform(-1.0, 0.2)), -1);
    return g;
  };
  auto eroded = [](const cv::Mat& g, int window) {
    cv::Mat out;
    cv::erode(g, out, cv::getStructuringElement(cv::MORPH_RECT, {window, window}), cv::Point(-1, -1), 1,
              cv::BORDER_REPLICATE);
    return out;
  };
  const cv::Mat wide = smooth_field({901, 697});
  for (const cv::Size size : {cv::Size(901, 697), cv::Size(61, 97), cv::Size(250, 47)})
    for (const int window : {21, 45, 65, 89, 121, 161, 223, 255, 401}) {
      CAPTURE(window);
      CAPTURE(size);
      const cv::Mat g = size == wide.size() ? wide : smooth_field(size);
      const cv::Mat d = labels_detail::local_darkest(g, window);
      REQUIRE(d.size() == g.size());
      const int tile = window / 16;
      if (tile < 2) {
        CHECK(cv::norm(d, eroded(g, window), cv::NORM_INF) == 0);
        continue;
      }
      const cv::Mat outer = eroded(g, window + 2 * tile), inner = eroded(g, window - 4 * tile);
      CHECK(cv::countNonZero(d < outer - 1e-6f) == 0);
      CHECK(cv::countNonZero(d > inner + 1e-6f) == 0);
      if (size != wide.size()) continue;
      // Close to the exact erosion on average: 0.007-0.039 of the range
      // (the window's half rounds down to whole samples), where the
      // image's global minimum everywhere would be several tenths.
      cv::Mat diff;
      cv::absdiff(d, eroded(g, window), diff);
      double lo = 0, hi = 0;
      cv::minMaxLoc(g, &lo, &hi);
      CHECK(cv::mean(diff)[0] < 0.05 * (hi - lo));
    }
}
