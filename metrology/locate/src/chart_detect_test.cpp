// detect_chart on exact renders of the generated MIL-STD-150A chart (the
// targets module's area-coverage raster): positive and negative, rotated
// by 90 and 180 degrees, mirrored; the anchors; no chart.
#include <cmath>
#include <string>

#include <doctest/doctest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "tactres/locate/chart_detect.h"
#include "tactres/targets/mil_std_chart.h"
#include "tactres/targets/raster.h"

using namespace tactres;

namespace {

constexpr double kPxPerMm = 30;

// Groups first..last at px_per_mm, printed (ink 0.05 on 0.85), slightly
// blurred.
cv::Mat chart_image(bool negative, int first_group = 0, int last_group = 3, double px_per_mm = kPxPerMm) {
  MilStdChartOptions o;
  o.first_group = first_group;
  o.last_group = last_group;
  const ImageF cov = coverage_raster(make_mil_std_chart(o), px_per_mm);
  cv::Mat img(cov.height, cov.width, CV_32F);
  for (int y = 0; y < cov.height; ++y)
    for (int x = 0; x < cov.width; ++x) {
      const float c = cov.pixels[size_t(y) * cov.width + x];
      img.at<float>(y, x) = negative ? 0.05f + 0.8f * c : 0.85f - 0.8f * c;
    }
  cv::GaussianBlur(img, img, {0, 0}, 0.8);
  return img;
}

// The elements a 30 px/mm render shows clearly: groups 0 and 1, and group 2
// down to element 3 (2.4 px per bar).
void check_indices(const ChartDetection& d) {
  REQUIRE(d.found);
  int found = 0;
  for (const ChartElement& e : d.elements) {
    CHECK(e.element >= 1);
    CHECK(e.element <= 6);
    if (found_in_image(d, e)) ++found;
    // The period follows the absolute index: 30 px/mm over lp/mm.
    const double want = kPxPerMm / std::exp2(e.group + (e.element - 1) / 6.0);
    CHECK(e.period_px == doctest::Approx(want).epsilon(0.12));
  }
  CHECK(found >= 14);
  CHECK(d.elements.front().group == 0);
  CHECK(d.elements.front().element == 1);
}

}  // namespace

TEST_CASE("chart detection: positive and negative, rotated and mirrored, anchored by --largest-group") {
  ChartDetectOptions o;
  o.largest_group = 0;
  for (bool negative : {false, true}) {
    const cv::Mat img = chart_image(negative);
    cv::Mat r90, r180, mirrored;
    const cv::Mat* upright = &img;
    cv::rotate(img, r90, cv::ROTATE_90_CLOCKWISE);
    cv::rotate(img, r180, cv::ROTATE_180);
    cv::flip(img, mirrored, 1);
    for (const auto& [view, name] : {std::pair(upright, "upright"), std::pair(static_cast<const cv::Mat*>(&r90), "90 deg"), std::pair(static_cast<const cv::Mat*>(&r180), "180 deg"),
                                     std::pair(static_cast<const cv::Mat*>(&mirrored), "mirrored")}) {
      CAPTURE(negative);
      CAPTURE(std::string(name));
      const ChartDetection d = detect_chart(*view, o);
      CHECK(d.light_bars == negative);
      CHECK(d.anchor == ChartAnchor::largest_group);
      CHECK(d.fibre_lattice_pitch_px == 0);  // a chart's bars make no honeycomb
      check_indices(d);
    }
  }
}

TEST_CASE("chart detection: an option the chart's own labels contradict stands, with the conflict said") {
  const cv::Mat img = chart_image(false);
  ChartDetectOptions right;
  right.largest_group = 0;
  const ChartDetection agreed = detect_chart(img, right);
  REQUIRE(agreed.found);
  CHECK(agreed.anchor_conflict.empty());
  ChartDetectOptions wrong;
  wrong.largest_group = 1;  // one group off what the chart's labels say
  const ChartDetection d = detect_chart(img, wrong);
  REQUIRE(d.found);
  CHECK(d.anchor == ChartAnchor::largest_group);
  CHECK(d.elements.front().group == 1);  // the option stands
  CHECK(d.anchor_conflict.find("makes the largest element found G1E1, but the chart itself says G0E1") !=
        std::string::npos);
}

TEST_CASE("chart detection: --px-per-mm anchors the group, no anchor keeps indices relative") {
  const cv::Mat img = chart_image(false);
  ChartDetectOptions o;
  o.px_per_mm = kPxPerMm;
  ChartDetection d = detect_chart(img, o);
  CHECK(d.anchor == ChartAnchor::px_per_mm);
  check_indices(d);
  // Frame only group 1 and finer: the largest found is G1E1 by the scale.
  const cv::Mat crop = img(cv::Rect(img.cols * 2 / 3, 0, img.cols / 3, img.rows * 2 / 3)).clone();
  d = detect_chart(crop, o);
  REQUIRE(d.found);
  CHECK(d.elements.front().group == 1);
  CHECK(d.elements.front().element == 1);
  // Without an anchor the same crop is relative: its largest is "G0E1".
  d = detect_chart(crop, {});
  REQUIRE(d.found);
  CHECK(d.anchor == ChartAnchor::none);
  CHECK(d.elements.front().group == 0);
  CHECK(d.elements.front().element == 1);
  CHECK(d.anchor_description.find("relative") != std::string::npos);
}

TEST_CASE("chart detection: a chart too fine for the pyramid's octaves is searched in both polarities at full size") {
  // Groups 2-3 at 20 px/mm: bars 2.5 px wide and finer, under the octaves'
  // 1.5 px floor one octave down (1.25 px), so the octaves show no element
  // of either polarity and full resolution must search both.
  for (bool negative : {false, true}) {
    CAPTURE(negative);
    const ChartDetection d = detect_chart(chart_image(negative, 2, 3, 20), {});
    REQUIRE(d.found);
    CHECK(d.light_bars == negative);
    int found = 0;
    for (const ChartElement& e : d.elements) found += found_in_image(d, e);
    CHECK(found >= 2);
    CHECK(0.5 * d.elements.front().period_px < 2.6);
  }
}

TEST_CASE("chart detection: one stray element of the other polarity does not hide a chart too fine for the octaves") {
  // The fine negative chart above, and beside it a bright card printed
  // with one coarse dark element (bars 8 px wide): the octaves see that
  // element and none of the chart's light bars.
  const cv::Mat chart = chart_image(true, 2, 3, 20);
  cv::Mat img(std::max(chart.rows, 200), chart.cols + 220, CV_32F, cv::Scalar(0.05));
  chart.copyTo(img(cv::Rect(0, 0, chart.cols, chart.rows)));
  const int x0 = chart.cols + 20, y0 = 10;
  img(cv::Rect(x0, y0, 180, 180)).setTo(0.85);
  constexpr int kBar = 8;
  for (int k = -1; k <= 1; ++k) {
    // H triplet (bars along x) left of the V triplet (bars along y), 3.5 periods apart.
    img(cv::Rect(x0 + 60 - 20, y0 + 90 + 2 * k * kBar - kBar / 2, 40, kBar)).setTo(0.05);
    img(cv::Rect(x0 + 116 + 2 * k * kBar - kBar / 2, y0 + 90 - 20, kBar, 40)).setTo(0.05);
  }
  cv::GaussianBlur(img, img, {0, 0}, 0.8);
  const ChartDetection d = detect_chart(img, {});
  REQUIRE(d.found);
  CHECK(d.light_bars);
  int found = 0;
  for (const ChartElement& e : d.elements) found += found_in_image(d, e);
  CHECK(found >= 2);
}

namespace {

// `chart` with its right half lit 100x dimmer than its left, and photon
// noise (variance growing with the light).
cv::Mat lit_unevenly(cv::Mat chart, double noise_at_one) {
  cv::RNG rng(7);
  for (int y = 0; y < chart.rows; ++y)
    for (int x = 0; x < chart.cols; ++x) {
      float& v = chart.at<float>(y, x);
      v *= x < chart.cols / 2 ? 1.0f : 0.01f;
      v += static_cast<float>(rng.gaussian(noise_at_one * std::sqrt(std::max(v, 0.0f))));
    }
  return chart;
}

}  // namespace

TEST_CASE("chart detection: a chart lit unevenly under photon noise is found in the square root of its light") {
  // In linear light the lit half's noise sets the bar margin and the dim
  // half's bars fall under it; in the square root the noise is alike
  // everywhere. The square root must be searched at full resolution
  // whether or not its octaves show more: the finer chart's dim half shows
  // in no octave of either scale (searched only where the octaves showed
  // more, it gave no chart).
  struct Case {
    std::string what;
    int first_group, last_group;
    double px_per_mm, noise_at_one;
    int min_dim;  // found in the dim half: 7 and 4 (linear light alone: 0)
  };
  for (const Case& c :
       {Case{"groups 0-2, 30 px/mm", 0, 2, 30, 0.02, 5}, Case{"groups 3-5, 60 px/mm", 3, 5, 60, 0.005, 3}}) {
    CAPTURE(c.what);
    const cv::Mat img = lit_unevenly(chart_image(false, c.first_group, c.last_group, c.px_per_mm), c.noise_at_one);
    const ChartDetection d = detect_chart(img, {});
    REQUIRE(d.found);
    int dim = 0;
    for (const ChartElement& e : d.elements)
      if (found_in_image(d, e) && d.patterns[e.h >= 0 ? e.h : e.v].center_px.x > img.cols / 2 + 10) ++dim;
    MESSAGE(c.what << ": " << dim << " elements found in the dim half");
    CHECK(dim >= c.min_dim);
  }
}

TEST_CASE("chart detection: no chart, and bad options") {
  cv::Mat noise(300, 400, CV_32F);
  cv::randn(noise, 0.5, 0.05);
  const ChartDetection d = detect_chart(noise, {});
  CHECK_FALSE(d.found);
  CHECK(d.problem.find("no USAF-1951 chart") != std::string::npos);
  ChartDetectOptions o;
  o.largest_group = 1;
  o.px_per_mm = 10;
  CHECK_THROWS_AS(o.validate(), std::invalid_argument);
  o = {};
  o.largest_element = 7;
  CHECK_THROWS_AS(o.validate(), std::invalid_argument);
}

namespace {

// One triplet of bars `bar_px` wide and 5 bar widths long, dark on a
// noisy bright ground, bars along image x when `along_x`.
cv::Mat single_triplet(double bar_px, bool along_x, unsigned seed, bool light = false) {
  cv::Mat img(400, 400, CV_32F);
  cv::RNG rng(seed);
  rng.fill(img, cv::RNG::NORMAL, light ? 0.1 : 0.6, 0.05);
  for (int k = -1; k <= 1; ++k) {
    const double c = 200 + 2 * k * bar_px;
    cv::Rect2d r(c - 0.5 * bar_px, 200 - 2.5 * bar_px, bar_px, 5 * bar_px);  // vertical bars
    if (along_x) r = cv::Rect2d(r.y, r.x, r.height, r.width);
    img(cv::Rect(r)).setTo(light ? 0.6 : 0.1);
  }
  cv::GaussianBlur(img, img, {0, 0}, 1.0);
  return img;
}

}  // namespace

TEST_CASE("chart detection: a frame holding one large triplet is measured as a single pattern in the image's orientation") {
  for (const bool along_x : {false, true}) {
    CAPTURE(along_x);
    const ChartDetection d = detect_chart(single_triplet(20, along_x, 3), {});
    REQUIRE(d.found);
    CHECK(d.single_pattern);
    REQUIRE(d.elements.size() == 1);
    const ChartElement& e = d.elements.front();
    CHECK((along_x ? e.h : e.v) >= 0);
    CHECK((along_x ? e.v : e.h) == -1);
    CHECK(e.period_px == doctest::Approx(40).epsilon(0.05));
    CHECK(d.anchor == ChartAnchor::none);
    // Where it is, whichever pyramid level found it: the bars' pixels are
    // centred on (199.5, 199.5). Two octaves down (where 20 px bars are
    // found) a blob's centroid is good to about a tenth of a pixel there,
    // 0.4 px here; mapped back with the wrong pixel-centre convention it
    // was 1.5 px off.
    const Vec2 c = d.patterns[along_x ? e.h : e.v].center_px;
    CAPTURE(c.x);
    CAPTURE(c.y);
    CHECK(norm(c - Vec2{199.5, 199.5}) < 0.6);
  }
  // Light bars on a dark ground (a negative chart, a fluorescent target).
  const ChartDetection light = detect_chart(single_triplet(20, false, 5, true), {});
  REQUIRE(light.found);
  CHECK(light.single_pattern);
  CHECK(light.light_bars);
  // --largest-group anchors it.
  ChartDetectOptions o;
  o.largest_group = 2;
  o.largest_element = 2;
  const ChartDetection anchored = detect_chart(single_triplet(20, true, 6), o);
  REQUIRE(anchored.found);
  CHECK(anchored.anchor == ChartAnchor::largest_group);
  CHECK(anchored.elements.front().group == 2);
  CHECK(anchored.elements.front().element == 2);
  // A small triplet alone is not a chart: such patterns turn up in texture.
  const ChartDetection small = detect_chart(single_triplet(5, false, 4), {});
  CHECK_FALSE(small.found);
  CHECK_FALSE(small.single_pattern);
}

TEST_CASE("chart detection: a blob on one bar's edge barely turns the pattern (the three bars' mean direction)") {
  // The single large triplet, with dark blobs hanging on the middle bar's
  // left edge at its top and on its right edge at its bottom, as texture
  // particles do (dev_16): they turn that bar's second moments by several
  // degrees, the other two bars not at all.
  cv::Mat img = single_triplet(20, false, 7);
  cv::circle(img, {185, 160}, 7, cv::Scalar(0.1), cv::FILLED);
  cv::circle(img, {215, 240}, 7, cv::Scalar(0.1), cv::FILLED);
  const ChartDetection d = detect_chart(img, {});
  REQUIRE(d.found);
  REQUIRE(d.elements.size() == 1);
  const ChartElement& e = d.elements.front();
  REQUIRE(e.v >= 0);
  const Vec2 dir = d.patterns[e.v].bar_dir;
  const double off_deg = std::acos(std::min(1.0, std::abs(dir.y))) * 180 / M_PI;
  CAPTURE(off_deg);
  CHECK(off_deg < 1.2);  // the middle bar alone: 2.0 deg
}

TEST_CASE("chart detection: a sans-serif group number above an even group's element 1 anchors the chart") {
  // Real charts print an even group's number a second time, above its
  // element 1's H triplet towards the right end (dev_03's "4" and "6";
  // tests/realdata covers that maker's style, V triplet left of H). Here
  // on the generated chart's layout (H left of V everywhere) with its
  // seven-segment labels left out, so that only OCR can read the one
  // number drawn there, in a Hershey sans-serif face.
  constexpr double px_per_mm = 60;
  MilStdChartOptions o;
  o.first_group = 0;
  o.last_group = 3;
  TargetLayout L = make_mil_std_chart(o);
  std::erase_if(L.artwork, [](const ArtworkShape& s) { return s.role == ArtworkShape::Role::label; });
  const ElementLayout* e1 = nullptr;
  for (const ElementLayout& e : L.elements)
    if (e.group == 0 && e.element == 1 && e.orientation == BarOrientation::horizontal_bars) e1 = &e;
  REQUIRE(e1 != nullptr);
  // The number's place, 3.5 bar widths right of the H triplet's middle and
  // 4.1 above it, 2.8 tall; the generated layout puts the odd column's end
  // there, so that ground is cleared as a real chart leaves it.
  const double w = e1->bar_width_mm;
  const Vec2 label_mm{0.5 * (e1->bars_mm[0].x0 + e1->bars_mm[0].x1) + 3.5 * w,
                      0.5 * (e1->bars_mm[0].y0 + e1->bars_mm[2].y1) - 4.1 * w};
  const RectMm clear{label_mm.x - 1.6 * w, label_mm.y - 1.6 * w, label_mm.x + 1.6 * w, label_mm.y + 1.5 * w};
  std::erase_if(L.artwork, [&](const ArtworkShape& s) { return s.bounds_mm().overlap_area_mm2(clear) > 0; });
  const ImageF cov = coverage_raster(L, px_per_mm);
  cv::Mat img(cov.height, cov.width, CV_32F);
  for (int y = 0; y < cov.height; ++y)
    for (int x = 0; x < cov.width; ++x) img.at<float>(y, x) = 0.85f - 0.8f * cov.pixels[size_t(y) * cov.width + x];
  const double w_px = w * px_per_mm;
  const double cx = label_mm.x * px_per_mm, cy = label_mm.y * px_per_mm;
  const double text_h_px = 2.8 * w_px;
  const double scale = cv::getFontScaleFromHeight(cv::FONT_HERSHEY_SIMPLEX, static_cast<int>(text_h_px), 3);
  int baseline = 0;
  const cv::Size size = cv::getTextSize("0", cv::FONT_HERSHEY_SIMPLEX, scale, 3, &baseline);
  cv::Mat ink = cv::Mat::zeros(img.size(), CV_8U);
  cv::putText(ink, "0", cv::Point(int(cx - 0.5 * size.width), int(cy + 0.5 * size.height)), cv::FONT_HERSHEY_SIMPLEX,
              scale, cv::Scalar(255), 3, cv::LINE_AA);
  cv::Mat ink_f;
  ink.convertTo(ink_f, CV_32F, 0.8 / 255);
  img -= ink_f;
  cv::GaussianBlur(img, img, {0, 0}, 0.8);
  // Whole, and with the frame's bottom edge across G0E1's third H bar: the
  // H triplet is not found, only the V triplet beside it (its bars a tenth
  // shorter), and the number's place follows from that partial element.
  const int cut_rows = static_cast<int>((e1->bars_mm[2].y0 + 0.25 * e1->bar_width_mm) * px_per_mm);
  for (const cv::Mat& view : {img, cv::Mat(img.rowRange(0, cut_rows))}) {
    CAPTURE(view.rows);
    const ChartDetection d = detect_chart(view, {});
    REQUIRE(d.found);
    CHECK(d.arrangement.recognised);
    CHECK(d.anchor == ChartAnchor::printed_numbers);
    // Cut, the number is read where the partial element 1 puts it (whole,
    // the box search may read it first).
    if (view.rows < img.rows)
      CHECK(d.anchor_description.find("1 of 1 group number(s) read where the arrangement puts them") !=
            std::string::npos);
    // The largest element found is in group 0 (G0E1, or G0E2 when E1 is cut).
    CHECK(d.elements.front().group == 0);
    for (const ChartElement& e : d.elements) {
      const double want = px_per_mm / std::exp2(e.group + (e.element - 1) / 6.0);
      CHECK(e.period_px == doctest::Approx(want).epsilon(0.12));
    }
  }
}

namespace {

// One column of five elements of the series, as a crop of a chart that
// shows a single column: each element a horizontal-bar triplet left of a
// vertical-bar one, 2^(-1/6) the size of the one above, dark on light.
cv::Mat one_column(double first_bar_px, const std::vector<double>& size_error = {1, 1, 1, 1, 1},
                   bool vertical_bars = true) {
  cv::Mat img(900, 500, CV_32F);
  cv::RNG rng(11);
  rng.fill(img, cv::RNG::NORMAL, 0.6, 0.02);
  double y = 60;
  for (int k = 0; k < 5; ++k) {
    const double w = first_bar_px * std::exp2(-k / 6.0) * size_error[size_t(k)];
    const double h_x = 120, v_x = h_x + 7 * w;  // H-to-V centre distance: 3.5 periods
    for (int b = -1; b <= 1; ++b) {
      img(cv::Rect(cv::Rect2d(h_x - 2.5 * w, y + 2 * b * w - 0.5 * w, 5 * w, w))).setTo(0.1);  // horizontal bars
      if (vertical_bars) img(cv::Rect(cv::Rect2d(v_x + 2 * b * w - 0.5 * w, y - 2.5 * w, w, 5 * w))).setTo(0.1);
    }
    y += 9 * w;
  }
  cv::GaussianBlur(img, img, {0, 0}, 1.0);
  return img;
}

}  // namespace

TEST_CASE("chart detection: a single column in view is indexed step by step, with no scale gradient") {
  // Printed sizes a few percent off the series (well under half a step):
  // a gradient down the column fitted them better, and indexed the
  // elements 0, 1, 3, 5, 6.
  for (const std::vector<double>& size_error :
       {std::vector<double>{1, 1, 1, 1, 1}, std::vector<double>{0.944, 1.048, 1.052, 0.973, 1.037}}) {
    CAPTURE(size_error[0]);
    const ChartDetection d = detect_chart(one_column(14, size_error), {});
    REQUIRE(d.found);
    REQUIRE(d.elements.size() >= 5);  // and the column's next one, placed
    for (size_t k = 0; k < d.elements.size(); ++k) {
      CAPTURE(k);
      CHECK(d.elements[k].relative_index == static_cast<int>(k));
    }
  }
}

TEST_CASE("chart detection: a column whose vertical-bar patterns are out of view says so, and what to do") {
  // The horizontal-bar triplets alone (dev_13: a lit disc that cuts off
  // every partner): patterns, but no element.
  const ChartDetection d = detect_chart(one_column(14, {1, 1, 1, 1, 1}, false), {});
  CHECK_FALSE(d.found);
  CHECK(d.patterns.size() >= 3);
  CAPTURE(d.problem);
  CHECK(d.problem.find("all with bars along the image's x axis") != std::string::npos);
  CHECK(d.problem.find("crop the image to one pattern") != std::string::npos);  // bars of 14 px and less
  // Turned by 90 degrees: along y.
  cv::Mat turned;
  cv::rotate(one_column(14, {1, 1, 1, 1, 1}, false), turned, cv::ROTATE_90_CLOCKWISE);
  const ChartDetection t = detect_chart(turned, {});
  CHECK_FALSE(t.found);
  CHECK(t.problem.find("all with bars along the image's y axis") != std::string::npos);
  // A negative chart's column (light bars on a dark ground): its patterns
  // are the light ones, and the message counts those.
  const ChartDetection negative = detect_chart(0.7 - one_column(14, {1, 1, 1, 1, 1}, false), {});
  CHECK_FALSE(negative.found);
  CHECK(negative.light_bars);
  CAPTURE(negative.problem);
  CHECK(negative.problem.find("all with bars along the image's x axis") != std::string::npos);
  // Bars under the width one pattern alone is measured at: no crop offered.
  const ChartDetection fine = detect_chart(one_column(5, {1, 1, 1, 1, 1}, false), {});
  CHECK_FALSE(fine.found);
  CAPTURE(fine.problem);
  CHECK(fine.problem.find("bars along the image's x axis") != std::string::npos);
  CHECK(fine.problem.find("crop") == std::string::npos);
}
