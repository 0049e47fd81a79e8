// recognise_arrangement (chart_arrangement.cpp) on element positions of
// real MIL-STD-150A charts: the phase (index modulo 12), the handedness and
// the maker's style under rotation and mirroring, a second maker's tighter
// spacing, and refusals when the elements do not fix it.

#include <algorithm>
#include <cmath>
#include <optional>
#include <utility>
#include <vector>

#include <doctest/doctest.h>

#include "chart_detect_internal.h"
#include "real_chart_layout_test.h"

using namespace tactres;
using namespace tactres::locate_detail;
using namespace tactres::locate_test;

namespace {

struct View {
  double rotation_deg = 0;
  bool mirrored = false;
  double w_px = 40;       // W of the outer pair, px
  double y_stretch = 1;   // another maker's column spacing
};

Vec2 chart_position(int n, double y_stretch) {
  const PairSlot& s = kRealPair[n % 12];
  Vec2 p{s.hx, s.hy * y_stretch};
  if (n >= 12) p = kInnerPairOffset + 0.25 * p;
  return p;
}

// Elements n (0..23, pair 0 then the inner pair) as found in an image.
struct Built {
  ChartDetection D;
  ScaleField field;
};
Built build(const std::vector<int>& ns, const View& v) {
  Built b;
  const double a = v.rotation_deg * M_PI / 180, c = std::cos(a), s = std::sin(a);
  const double mx = v.mirrored ? -1 : 1;
  auto to_image = [&](Vec2 q) {  // chart W -> px
    const Vec2 m{mx * q.x * v.w_px, q.y * v.w_px};
    return Vec2{600 + c * m.x - s * m.y, 600 + s * m.x + c * m.y};
  };
  auto dir = [&](Vec2 q) { return Vec2{c * mx * q.x - s * q.y, s * mx * q.x + c * q.y}; };
  const int n0 = *std::min_element(ns.begin(), ns.end());
  for (int n : ns) {
    const double w_px = v.w_px * (n >= 12 ? 0.25 : 1) * std::exp2(-(n % 12) / 6.0);
    const Vec2 h = chart_position(n, v.y_stretch);
    const double v_dx = kRealPair[n % 12].v_dx * (n >= 12 ? 0.25 : 1);
    BarPattern ph, pv;
    ph.center_px = to_image(h);
    ph.bar_dir = dir({1, 0});
    pv.center_px = to_image(h + Vec2{v_dx, 0});
    pv.bar_dir = dir({0, 1});
    ph.period_px = pv.period_px = 2 * w_px;
    ChartElement e;
    e.h = static_cast<int>(b.D.patterns.size());
    b.D.patterns.push_back(ph);
    e.v = static_cast<int>(b.D.patterns.size());
    b.D.patterns.push_back(pv);
    e.period_px = 2 * w_px;
    e.relative_index = n - n0;
    b.D.elements.push_back(e);
  }
  b.field.cols = b.field.rows = 1200;
  b.field.half = 600;
  b.field.level0 = std::log(2 * v.w_px * std::exp2(-(n0 % 12) / 6.0) * (n0 >= 12 ? 0.25 : 1));
  return b;
}

View turned(double rotation_deg, bool mirrored) {
  View v;
  v.rotation_deg = rotation_deg;
  v.mirrored = mirrored;
  return v;
}

// The chart's +y in the image when turned by rotation_deg (and mirrored
// or not: a left-right mirror keeps it).
Vec2 image_down(double rotation_deg) {
  const double a = rotation_deg * M_PI / 180;
  return {-std::sin(a), std::cos(a)};
}

std::vector<int> range(int a, int b) {
  std::vector<int> out;
  for (int n = a; n <= b; ++n) out.push_back(n);
  return out;
}

}  // namespace

TEST_CASE("arrangement: a real chart's phase and handedness under rotation and mirroring") {
  for (double rot : {0.0, 37.0, 90.0, 191.0, 290.0})
    for (bool mirrored : {false, true}) {
      CAPTURE(rot);
      CAPTURE(mirrored);
      Built b = build(range(1, 16), turned(rot, mirrored));  // the even group's E2 .. the inner pair's E5
      recognise_arrangement(b.D, b.field);
      const auto& A = b.D.arrangement;
      REQUIRE(A.recognised);
      CHECK(A.phase == 1);
      CHECK(A.mirrored == mirrored);
      CHECK_FALSE(A.generated_style);
      // The chart's +y in the image: the rotated (and mirrored) y axis.
      CHECK(dot(A.down_px, image_down(rot)) > 0.99);
    }
}

TEST_CASE("arrangement: the phase follows the largest element found, and another maker's spacing") {
  for (int n0 : {0, 2, 4}) {  // two or more elements of each column of the outer pair in view
    CAPTURE(n0);
    View v;
    v.rotation_deg = 12;
    v.y_stretch = 0.84;  // a chart whose columns step 6.7 bar widths, not 8 (dev_14)
    Built b = build(range(n0, 13), v);
    recognise_arrangement(b.D, b.field);
    CAPTURE(b.D.arrangement.note);
    REQUIRE(b.D.arrangement.recognised);
    CHECK(b.D.arrangement.phase == n0 % 12);
  }
}

TEST_CASE("arrangement: refused when the elements found do not fix it") {
  SUBCASE("three elements") {
    Built b = build({7, 8, 9}, View{});
    recognise_arrangement(b.D, b.field);
    CHECK_FALSE(b.D.arrangement.recognised);
  }
  SUBCASE("one column only: a column of the even or of the odd group looks the same") {
    Built b = build(range(7, 11), View{});
    recognise_arrangement(b.D, b.field);
    CHECK_FALSE(b.D.arrangement.recognised);
  }
  SUBCASE("elements scattered at random, not in the arrangement") {
    Built b = build(range(1, 16), View{});
    // Swap the positions of every other pair of elements.
    for (size_t i = 0; i + 1 < b.D.elements.size(); i += 4) std::swap(b.D.elements[i].h, b.D.elements[i + 1].h);
    recognise_arrangement(b.D, b.field);
    CHECK_FALSE(b.D.arrangement.recognised);
  }
}

TEST_CASE("arrangement: the ways it fits when the elements found fit it alike in several") {
  // The even group's element 1 and its column (dev_01, dev_02): as found,
  // and mirrored as an even group's element 6 followed by the odd group's
  // column, they fit alike; every way within 3 observations of the best
  // (the margin that refuses it) is offered for the printed numbers, the
  // best first.
  for (double rot : {0.0, 191.0})
    for (bool mirrored : {false, true}) {
      CAPTURE(rot);
      CAPTURE(mirrored);
      Built b = build(range(0, 5), turned(rot, mirrored));
      std::vector<ChartDetection::Arrangement> ways;
      recognise_arrangement(b.D, b.field, &ways);
      CHECK_FALSE(b.D.arrangement.recognised);
      REQUIRE(ways.size() >= 2);
      REQUIRE(ways.size() <= kMaxArrangementWays);
      const auto truth = std::find_if(ways.begin(), ways.end(), [&](const ChartDetection::Arrangement& w) {
        return w.phase == 0 && w.mirrored == mirrored;
      });
      REQUIRE(truth != ways.end());
      CHECK(dot(truth->down_px, image_down(rot)) > 0.99);
      CHECK(truth->steps_matched == truth->steps_checked);
      // Each way's phase is a candidate of the unrecognised arrangement
      // (predict_column_ends), and a way holds none of its own.
      REQUIRE(b.D.arrangement.candidate_phases.size() == ways.size());
      for (size_t i = 0; i < ways.size(); ++i) {
        const ChartDetection::Arrangement& w = ways[i];
        CHECK(w.recognised);
        CHECK(w.steps_matched <= ways.front().steps_matched);
        CHECK(ways.front().steps_matched - w.steps_matched < 3);
        CHECK(b.D.arrangement.candidate_phases[i] == w.phase);
        CHECK(w.candidate_phases.empty());
      }
    }
  SUBCASE("a recognised or refused arrangement offers none") {
    std::vector<ChartDetection::Arrangement> ways(1);
    Built whole = build(range(1, 16), View{});
    recognise_arrangement(whole.D, whole.field, &ways);
    CHECK(whole.D.arrangement.recognised);
    CHECK(ways.empty());
    ways.resize(1);
    Built three = build({7, 8, 9}, View{});
    recognise_arrangement(three.D, three.field, &ways);
    CHECK(ways.empty());
  }
}

TEST_CASE("column ends: a recognised arrangement ends a column at element 6, anchored or not") {
  // The outer pair's even group, elements 2..6 (n 1..5): its column ends at
  // element 6, where the odd group's element 1 stands elsewhere (dev_03: a
  // step placed below G6E6 was measured on empty ground).
  // (One column alone does not fix the arrangement; these views take it as
  // recognised, with the phase of element n = 1, as the whole chart would.)
  View v;
  Built b = build(range(1, 5), v);
  b.D.arrangement.recognised = true;
  b.D.arrangement.phase = 1;
  REQUIRE(b.D.anchor == ChartAnchor::none);
  predict_column_ends(b.D);
  CHECK(b.D.predicted_elements == 0);
  // Elements 2..4 of the same column found: the column runs on to element 6,
  // two steps, not the one step of an unrecognised chart.
  Built c = build(range(1, 3), v);
  c.D.arrangement.recognised = true;
  c.D.arrangement.phase = 1;
  predict_column_ends(c.D);
  CHECK(c.D.predicted_elements == 2);
  for (const BarPattern& p : c.D.patterns) CHECK_FALSE(p.nested);  // a column's, not the nesting's
  // Not recognised: one step beyond three in a row.
  Built d = build(range(1, 3), v);
  predict_column_ends(d.D);
  CHECK(d.D.predicted_elements == 1);
  // Not recognised, as it fits in two ways: the step is placed only where
  // both continue the column. The three found are n 1..3 under phase 1,
  // or n 4..6 under phase 4, where the even group's column ends at n = 5
  // and the next (the odd group's element 1) heads the other column.
  Built e = build(range(1, 3), v);
  e.D.arrangement.candidate_phases = {1, 4};
  predict_column_ends(e.D);
  CHECK(e.D.predicted_elements == 0);
  Built f = build(range(1, 3), v);
  f.D.arrangement.candidate_phases = {1, 2};  // n 1..4 or 2..5: one column either way
  predict_column_ends(f.D);
  CHECK(f.D.predicted_elements == 1);
}

namespace {

// Where element n's patterns stand in view v (the fixture's real pairs,
// nested by kInnerPairOffset), from a build of every element.
double true_period_px(int n, const View& v) {
  return 2 * v.w_px * (n >= 12 ? 0.25 : 1) * std::exp2(-(n % 12) / 6.0);
}

std::pair<Vec2, Vec2> true_centres(int n, const View& v) {
  const Built all = build(range(0, 23), v);
  const ChartElement& e = all.D.elements[static_cast<size_t>(n)];
  return {all.D.patterns[e.h].center_px, all.D.patterns[e.v].center_px};
}

}  // namespace

TEST_CASE("nesting: the inner pair is the outer one a quarter the size, and its missing elements are placed") {
  View v;
  v.rotation_deg = 191;  // a turned frame (dev_01)
  v.mirrored = true;
  v.w_px = 16;  // the whole chart in the 1200 px frame
  // The whole outer pair and three elements of the inner one found; the
  // arrangement recognised with the phase of n = 0.
  std::vector<int> ns = range(0, 11);
  for (int n : {12, 13, 14}) ns.push_back(n);
  Built b = build(ns, v);
  std::vector<ChartElement> E = b.D.elements;
  const std::optional<Vec2> centre = fit_nesting(b.D, E);
  REQUIRE(centre);
  CHECK(E.size() == b.D.elements.size());
  b.D.arrangement.recognised = true;
  b.D.arrangement.phase = 0;
  predict_nested_pairs(b.D, *centre, 1200, 1200);
  // The rest of the inner pair (n 15..23), where the chart has it; nothing
  // two pairs in, where no element was found.
  CHECK(b.D.predicted_elements == 9);
  for (const ChartElement& e : b.D.elements) {
    CAPTURE(e.relative_index);
    CHECK(e.relative_index <= 23);
    CHECK(b.D.patterns[e.h].nested == b.D.patterns[e.h].predicted);
    if (!b.D.patterns[e.h].predicted) continue;
    CHECK(b.D.patterns[e.v].nested);
    const auto [h, vc] = true_centres(e.relative_index, v);
    CHECK(norm(b.D.patterns[e.h].center_px - h) < 0.01);
    CHECK(norm(b.D.patterns[e.v].center_px - vc) < 0.01);
    CHECK(b.D.patterns[e.h].period_px == doctest::Approx(true_period_px(e.relative_index, v)));
  }
}

namespace {

// The relative indices of `E`, in order.
std::vector<int> indices_of(const std::vector<ChartElement>& E) {
  std::vector<int> out;
  for (const ChartElement& e : E) out.push_back(e.relative_index);
  return out;
}

// Build `ns`, then give the elements in `misread` the index `by` off theirs
// (as a blurred binarised period would), in index order.
std::pair<Built, std::vector<ChartElement>> misread(const std::vector<int>& ns, const std::vector<int>& wrong, int by,
                                                    const View& v) {
  Built b = build(ns, v);
  std::vector<ChartElement> E = b.D.elements;
  for (ChartElement& e : E)
    if (std::count(wrong.begin(), wrong.end(), e.relative_index)) e.relative_index += by;
  sort_by_index(E);
  return {std::move(b), std::move(E)};
}

}  // namespace

TEST_CASE("nesting: fine elements that blur put one index off are re-indexed by their position") {
  View v;
  v.w_px = 12;  // the inner pair's periods are under 8 px, so their indices come from blurred periods
  std::vector<int> ns = range(0, 9);
  for (int n : {12, 13, 14, 16}) ns.push_back(n);
  // One element one index high: 14 taken for 15.
  {
    auto [b, E] = misread(ns, {14}, +1, v);
    REQUIRE(fit_nesting(b.D, E));
    CHECK(indices_of(E) == ns);
  }
  // A run one index low (the way blur biases a binarised period): 13, 14
  // taken for 12, 13, with 12 itself not found. Moving them all at once
  // frees each one's place for the next.
  {
    std::vector<int> run = range(0, 9);
    for (int n : {13, 14, 16}) run.push_back(n);
    auto [b, E] = misread(run, {13, 14}, -1, v);
    REQUIRE(fit_nesting(b.D, E));
    CHECK(indices_of(E) == run);
  }
  // A move onto an index that an element keeps is not made: a second
  // element found at 14's place but indexed 15 would move to 14.
  {
    Built b = build(ns, v);
    std::vector<ChartElement> E = b.D.elements;
    ChartElement twin = *std::find_if(E.begin(), E.end(), [](const ChartElement& e) { return e.relative_index == 14; });
    twin.relative_index = 15;
    E.push_back(twin);
    sort_by_index(E);
    const std::vector<int> before = indices_of(E);
    REQUIRE(fit_nesting(b.D, E));
    CHECK(indices_of(E) == before);
  }
}

TEST_CASE("nesting: lone patterns of fine elements join one complete element that nests") {
  View v;
  v.w_px = 12;
  // The inner pair shows element 13 whole, indexed 14 (its blurred period
  // 4 % short, as in dev_05 resized by 0.8), and one triplet each of
  // elements 12 and 15.
  std::vector<int> ns = range(0, 11);
  for (int n : {12, 13, 15}) ns.push_back(n);
  Built b = build(ns, v);
  std::vector<ChartElement> kept, partial;
  for (ChartElement e : b.D.elements) {
    if (e.relative_index == 12) e.v = -1;
    if (e.relative_index == 15) e.h = -1;
    if (e.relative_index == 13) e.relative_index = 14;
    (e.h < 0 || e.v < 0 ? partial : kept).push_back(e);
  }
  // The complete element alone is no evidence: its index stays.
  {
    std::vector<ChartElement> E = kept;
    CHECK_FALSE(fit_nesting(b.D, E));
    CHECK(E.back().relative_index == 14);
  }
  // With the lone patterns, four patterns nest: the point is the chart's,
  // and the complete element takes its index back.
  {
    std::vector<ChartElement> E = kept;
    const std::optional<Vec2> centre = fit_nesting(b.D, E, partial);
    REQUIRE(centre);
    CHECK(E.back().relative_index == 13);
    const Built all = build(range(0, 23), v);
    std::vector<ChartElement> every = all.D.elements;
    const std::optional<Vec2> truth = fit_nesting(all.D, every);
    REQUIRE(truth);
    CHECK(norm(*centre - *truth) < 0.5);
  }
  // Four lone patterns, with no complete element among them, nest nothing.
  {
    std::vector<int> inner = range(0, 11);
    for (int n : {12, 13, 14, 15}) inner.push_back(n);
    Built four = build(inner, v);
    std::vector<ChartElement> E, lone;
    for (ChartElement e : four.D.elements) {
      if (e.relative_index >= 12) (e.relative_index < 14 ? e.v : e.h) = -1;
      (e.relative_index >= 12 ? lone : E).push_back(e);
    }
    CHECK_FALSE(fit_nesting(four.D, E, lone));
  }
  // A lone pattern off the nesting (another layout) does not count.
  {
    Built off = build(ns, v);
    std::vector<ChartElement> E = kept;
    std::vector<ChartElement> lone = partial;
    off.D.patterns[lone.back().v].center_px = off.D.patterns[lone.back().v].center_px + Vec2{9, 0};
    CHECK_FALSE(fit_nesting(off.D, E, lone));
    CHECK(E.back().relative_index == 14);
  }
}

TEST_CASE("nesting: no pattern is placed twice, under two indices") {
  View v;
  v.w_px = 12;
  std::vector<int> ns = range(0, 11);
  for (int n : {13, 14, 15}) ns.push_back(n);
  auto [b, E] = misread(ns, {13, 14, 15}, -1, v);
  const std::optional<Vec2> centre = fit_nesting(b.D, E);
  REQUIRE(centre);
  b.D.elements = E;
  b.D.arrangement.recognised = true;
  b.D.arrangement.phase = 0;
  predict_nested_pairs(b.D, *centre, 1200, 1200);
  for (size_t i = 0; i < b.D.elements.size(); ++i)
    for (size_t j = i + 1; j < b.D.elements.size(); ++j) {
      CAPTURE(b.D.elements[i].relative_index);
      CAPTURE(b.D.elements[j].relative_index);
      CHECK(norm(b.D.patterns[b.D.elements[i].h].center_px - b.D.patterns[b.D.elements[j].h].center_px) > 1);
    }
}

TEST_CASE("nesting: nothing is placed without two elements that nest, or into a pair with none found") {
  View v;
  // The outer pair alone: nothing nests.
  Built outer = build(range(0, 11), v);
  std::vector<ChartElement> E = outer.D.elements;
  CHECK_FALSE(fit_nesting(outer.D, E));
  // One inner element: one element is no evidence.
  std::vector<int> ns = range(0, 11);
  ns.push_back(13);
  Built one = build(ns, v);
  E = one.D.elements;
  CHECK_FALSE(fit_nesting(one.D, E));
  // Two inner elements, but placed off the nesting (another layout).
  ns.push_back(14);
  Built off = build(ns, v);
  off.D.patterns[off.D.elements.back().h].center_px = off.D.patterns[off.D.elements.back().h].center_px + Vec2{9, 0};
  E = off.D.elements;
  CHECK_FALSE(fit_nesting(off.D, E));
  // Unnumbered (no anchor, arrangement not recognised): which pair an
  // index is in is unknown, so nothing is placed.
  Built rel = build(range(0, 14), v);
  E = rel.D.elements;
  const std::optional<Vec2> centre = fit_nesting(rel.D, E);
  REQUIRE(centre);
  predict_nested_pairs(rel.D, *centre, 1200, 1200);
  CHECK(rel.D.predicted_elements == 0);
}

TEST_CASE("nesting: two small inner elements off their places by a blurred pattern's error still nest") {
  // W 12 px: the inner pair's elements 14 and 16 have periods of 4.8 and
  // 3.8 px. Each H triplet found 2.2 px off its place, the two in opposite
  // directions (dev_04 turned by 5 degrees: 2.1 px): about the point either
  // gives alone the other lies 3.3 px off, about the point they give
  // together each lies 2.2 px off.
  View v;
  v.w_px = 12;
  std::vector<int> ns = range(0, 11);
  for (int n : {14, 16}) ns.push_back(n);
  for (const double off_px : {2.2, 4.0}) {
    CAPTURE(off_px);
    Built b = build(ns, v);
    const auto moved = [&](int n) -> Vec2& {
      for (const ChartElement& e : b.D.elements)
        if (e.relative_index == n) return b.D.patterns[e.h].center_px;
      FAIL("no element " << n);
      return b.D.patterns[0].center_px;
    };
    moved(14) = moved(14) + Vec2{off_px, 0};
    moved(16) = moved(16) - Vec2{off_px, 0};
    std::vector<ChartElement> E = b.D.elements;
    const std::optional<Vec2> centre = fit_nesting(b.D, E);
    // 4 px off (a bar's width and more) is another layout, not an error of place.
    CHECK(centre.has_value() == (off_px < 3));
    if (!centre) continue;
    CHECK(indices_of(E) == ns);
    // The point of the exact nesting: the two errors cancel.
    const auto [h12, v12] = true_centres(12, v);
    const auto [h0, v0] = true_centres(0, v);
    const Vec2 exact_px = (1 / 0.75) * (h12 - 0.25 * h0);
    CHECK(norm(*centre - exact_px) < 0.1);
  }
}

TEST_CASE("partial elements: a lone pattern must run along the chart's axes (a blurred numeral is no element)") {
  // Bars turned from chart x (an H triplet) or near chart y (a V one).
  for (const double tilt_deg : {0.0, 4.0, 11.0, 20.0, 86.0, 79.0}) {
    CAPTURE(tilt_deg);
    const double off_axis_deg = std::min(std::abs(tilt_deg), std::abs(90 - tilt_deg));
    Built b = build(range(0, 9), View{});
    // Element 10's triplet, alone, its bars turned by tilt_deg.
    BarPattern p;
    p.center_px = b.D.patterns[b.D.elements.back().h].center_px + Vec2{0, 60};
    const double a = tilt_deg * M_PI / 180;
    p.bar_dir = {std::cos(a), std::sin(a)};
    p.period_px = 2 * 40 * std::exp2(-10 / 6.0);
    b.D.patterns.push_back(p);
    const cv::Mat img(1200, 1200, CV_32F, cv::Scalar(0));
    const std::vector<ChartElement> partial =
        partial_elements(b.D, {static_cast<int>(b.D.patterns.size()) - 1}, b.field, img);
    REQUIRE(partial.size() == (off_axis_deg < 8.5 ? 1u : 0u));
    if (!partial.empty()) {
      CHECK(partial[0].relative_index == 10);
      CHECK((tilt_deg < 45 ? partial[0].h : partial[0].v) == static_cast<int>(b.D.patterns.size()) - 1);
    }
  }
}

TEST_CASE("partial elements: a lone pattern where the missing partner stands completes the element") {
  // Element 9's V triplet alone, and an H triplet near where its partner
  // stands, `h_scale` times the period the partner should have (a field's
  // distortion squeezes it), `off` periods from the place, its bars turned
  // `turn_deg` from chart x.
  struct Case {
    double h_scale, off, turn_deg;
    bool recognised, joins;
  };
  for (const Case c : {Case{0.85, 0.2, 0, false, true}, Case{1.2, 0.3, 5, false, true}, Case{0.7, 0.2, 0, false, false},
                       Case{0.85, 0.8, 0, false, false}, Case{0.85, 0.2, 20, false, false},
                       Case{0.85, 0.2, 0, true, true}, Case{0.7, 0.2, 0, true, false}}) {
    CAPTURE(c.h_scale);
    CAPTURE(c.off);
    CAPTURE(c.turn_deg);
    CAPTURE(c.recognised);
    Built b = build(range(0, 8), View{});
    Built nine = build({9}, View{});
    BarPattern pv = nine.D.patterns[nine.D.elements[0].v];
    const int kv = static_cast<int>(b.D.patterns.size());
    b.D.patterns.push_back(pv);
    if (c.recognised) b.D.arrangement.recognised = true;  // phase 0, upright, the maker's style
    // Unrecognised, the side is the nearest complete element's.
    const ChartElement* near = &b.D.elements[0];
    for (const ChartElement& e : b.D.elements)
      if (norm(b.D.patterns[e.h].center_px - pv.center_px) < norm(b.D.patterns[near->h].center_px - pv.center_px))
        near = &e;
    const Vec2 d = b.D.patterns[near->v].center_px - b.D.patterns[near->h].center_px;
    const Vec2 h_to_v =
        c.recognised ? double(h_side(9, false)) * chart_x_px(b.D.arrangement) : (1.0 / norm(d)) * d;
    BarPattern ph = pv;
    const double a = c.turn_deg * M_PI / 180;
    ph.bar_dir = {std::cos(a), std::sin(a)};
    ph.period_px = c.h_scale * pv.period_px;
    ph.center_px = pv.center_px - (b.D.separation_periods * pv.period_px) * h_to_v + Vec2{0, c.off * pv.period_px};
    const int kh = kv + 1;
    b.D.patterns.push_back(ph);
    const cv::Mat img(1200, 1200, CV_32F, cv::Scalar(0));
    const std::vector<int> lone{kv, kh};
    std::vector<ChartElement> partial = partial_elements(b.D, lone, b.field, img);
    // At 0.7 the H triplet indexes a partial element of its own (12).
    REQUIRE(partial.size() == (c.h_scale == 0.7 ? 2u : 1u));
    REQUIRE(partial[0].v == kv);
    REQUIRE(partial[0].relative_index == 9);
    number_partial_elements(b.D, partial, lone, 1200, 1200);
    const auto nine_it = std::find_if(b.D.elements.begin(), b.D.elements.end(),
                                      [](const ChartElement& e) { return e.relative_index == 9; });
    if (c.joins) {
      REQUIRE(nine_it != b.D.elements.end());
      CHECK(nine_it->h == kh);
      CHECK(nine_it->v == kv);
      CHECK(nine_it->partner_joined);
      CHECK(index_from_one_pattern(b.D, *nine_it));
      CHECK(b.D.partners_placed == 0);
      CHECK(b.D.partial.empty());
    } else if (c.recognised) {  // placed as predicted, not joined
      REQUIRE(nine_it != b.D.elements.end());
      CHECK_FALSE(nine_it->partner_joined);
      CHECK(b.D.patterns[nine_it->h].predicted);
      CHECK(b.D.partners_placed == static_cast<int>(partial.size()));  // each partial element's
    } else {
      CHECK(nine_it == b.D.elements.end());
      REQUIRE(b.D.partial.size() == partial.size());
      CHECK(b.D.partial[0].h < 0);
      CHECK(b.D.partial[0].partial == ChartElement::Partial::partner_not_found);
    }
  }
}
