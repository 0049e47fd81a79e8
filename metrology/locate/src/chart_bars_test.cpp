// The run-based component labelling of chart detection (run_components,
// chart_detect_internal.h) against OpenCV's: the same 8-connected
// partition of random masks of every density, widths that are and are not
// multiples of 8, and the shapes that test the diagonal rule; and the local
// contrast of its binarisation (local_contrast) against cv::blur; the
// pairing of patterns into elements (pair_patterns).
#include <cmath>
#include <map>
#include <random>
#include <tuple>

#include <doctest/doctest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "chart_detect_internal.h"

using namespace tactres;
using namespace tactres::locate_detail;

namespace {

// True when run_components and cv::connectedComponents (connectivity 8)
// partition the marked pixels of `mask` alike: each root maps to one label
// and each label to one root. Also returns the component count.
bool same_partition(const cv::Mat& mask, int* components = nullptr) {
  std::vector<MaskRun> runs;
  const std::vector<int> root = run_components(mask, runs);
  cv::Mat labels;
  const int n = cv::connectedComponents(mask, labels, 8, CV_32S);
  std::map<int, int> root_to_label, label_to_root;
  long long marked = 0;
  if (root.size() != runs.size()) return false;
  for (size_t i = 0; i < runs.size(); ++i) {
    // A root is the index of its component's first run, and its own root.
    if (root[i] < 0 || root[i] > static_cast<int>(i) || root[root[i]] != root[i]) return false;
    if (i > 0 && std::tuple(runs[i - 1].y, runs[i - 1].x1) >= std::tuple(runs[i].y, runs[i].x0)) return false;
  }
  for (size_t i = 0; i < runs.size(); ++i)
    for (int x = runs[i].x0; x <= runs[i].x1; ++x) {
      const int l = labels.at<int>(runs[i].y, x);
      if (l == 0) return false;  // a run over an unmarked pixel
      ++marked;
      const auto [a, new_a] = root_to_label.emplace(root[i], l);
      const auto [b, new_b] = label_to_root.emplace(l, root[i]);
      if (a->second != l || b->second != root[i]) return false;
    }
  if (components) *components = static_cast<int>(root_to_label.size());
  return marked == cv::countNonZero(mask) && static_cast<int>(root_to_label.size()) == n - 1;
}

}  // namespace

TEST_CASE("run_components: the 8-connected partition of cv::connectedComponents") {
  std::mt19937 rng(11);
  for (const int width : {1, 7, 8, 9, 64, 203})
    for (const double density : {0.0, 0.02, 0.3, 0.6, 1.0}) {
      CAPTURE(width);
      CAPTURE(density);
      cv::Mat mask(37, width, CV_8U);
      std::bernoulli_distribution marked(density);
      for (int y = 0; y < mask.rows; ++y)
        for (int x = 0; x < width; ++x) mask.at<unsigned char>(y, x) = marked(rng) ? 255 : 0;
      CHECK(same_partition(mask));
    }
}

TEST_CASE("run_components: diagonal neighbours join, a one-pixel gap does not, a U shape is one component") {
  cv::Mat mask(8, 24, CV_8U, cv::Scalar(0));
  // Two runs touching only at a corner: one component.
  mask(cv::Rect(2, 1, 3, 1)).setTo(255);
  mask(cv::Rect(5, 2, 3, 1)).setTo(255);
  // Two runs a pixel apart, one above the other: two components.
  mask(cv::Rect(12, 1, 3, 1)).setTo(255);
  mask(cv::Rect(16, 2, 3, 1)).setTo(255);
  // A U whose arms meet only on its last row: one component, found late.
  mask(cv::Rect(1, 4, 1, 4)).setTo(255);
  mask(cv::Rect(9, 4, 1, 4)).setTo(255);
  mask(cv::Rect(1, 7, 9, 1)).setTo(255);
  int components = 0;
  CHECK(same_partition(mask, &components));
  CHECK(components == 4);
}

// The image less its integral image's box means (local_contrast) against
// the image less cv::blur's: band edges (64 rows), images shorter than a
// band or than a window, one row, both windows at once, and a region of a
// larger image (both read the pixels around it, as OpenCV's filters do).
TEST_CASE("local_contrast: the image less cv::blur's means (BORDER_REFLECT), band by band") {
  cv::RNG rng(5);
  cv::Mat parent(320, 240, CV_32F);
  rng.fill(parent, cv::RNG::UNIFORM, 0.0, 1000.0);
  for (const cv::Size size : {cv::Size(5, 3), cv::Size(40, 17), cv::Size(203, 64), cv::Size(131, 65),
                              cv::Size(97, 300), cv::Size(60, 1), cv::Size(0, 0)}) {
    CAPTURE(size);
    // Size (0, 0): a region of `parent`, 2 px in from its left and top edges.
    cv::Mat img = size.area() == 0 ? parent(cv::Rect(2, 2, 150, 90)) : cv::Mat(size, CV_32F);
    if (size.area() > 0) rng.fill(img, cv::RNG::UNIFORM, 0.0, 1000.0);
    const std::vector<int> windows{7, 15};
    std::vector<cv::Mat> contrast;
    local_contrast(img, windows, contrast);
    REQUIRE(contrast.size() == 2);
    for (size_t i = 0; i < windows.size(); ++i) {
      cv::Mat expected;
      cv::blur(img, expected, {windows[i], windows[i]}, {-1, -1}, cv::BORDER_REFLECT);
      expected = img - expected;
      CAPTURE(windows[i]);
      REQUIRE(contrast[i].size() == img.size());
      CHECK(cv::norm(contrast[i], expected, cv::NORM_INF) <= 1e-3);  // float rounding of values up to 1000
    }
  }
}

TEST_CASE("pair_patterns: of two H triplets beside a V one, the level one pairs, not one a period along") {
  // A V triplet, and two H triplets 3.5 periods to its left: one level with
  // it whose binarised period reads 3 % short, and one found 0.75 period
  // down its column (two of its bars and the ground's shoulder: dev_04
  // resized 1.25 times) whose period matches. (A whole period down, the
  // line between the centres turns 16 degrees from the H bars, past the
  // pairing's 15.)
  for (const double turn_deg : {0.0, 30.0, 90.0}) {
    CAPTURE(turn_deg);
    const double a = turn_deg * M_PI / 180;
    const Vec2 x{std::cos(a), std::sin(a)}, y{-std::sin(a), std::cos(a)};
    const double p = 8;
    const auto pattern = [&](Vec2 at, Vec2 bar_dir, double period) {
      BarPattern b;
      b.center_px = Vec2{300, 300} + at.x * x + at.y * y;
      b.bar_dir = bar_dir;
      b.period_px = period;
      b.bar_length_px = 2.5 * period;
      return b;
    };
    const std::vector<BarPattern> P{pattern({0, 0}, y, p), pattern({-3.5 * p, 0}, x, 0.97 * p),
                                    pattern({-3.5 * p, 0.75 * p}, x, p)};
    const Pairing pairing = pair_patterns(P);
    REQUIRE(pairing.elements.size() == 1u);
    CHECK(pairing.elements[0].v == 0);
    CHECK(pairing.elements[0].h == 1);
  }
}
