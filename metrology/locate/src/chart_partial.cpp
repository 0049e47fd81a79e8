// Partial elements (ChartElement::partial, chart_detect.h): elements of
// which only one pattern was found, and the placing of the missing one
// where the recognised arrangement says it stands.

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "chart_detect_internal.h"

namespace tactres::locate_detail {

namespace {

// How far a lone pattern's bars may turn from the chart's axes (above).
constexpr double kLoneAxisTolerance = 8.5 * M_PI / 180;

// Where the missing pattern of partial element `e` stands:
// D.separation_periods along `h_to_v` (the image direction from an H
// triplet to its V partner) from the found one; returned. Whether it would
// lie in the image (with its strip's margin) sets e.partial and its reason.
Vec2 place_partner(const ChartDetection& D, ChartElement& e, Vec2 h_to_v, int cols, int rows) {
  const bool is_h = e.h >= 0;
  const BarPattern& p = D.patterns[is_h ? e.h : e.v];
  const Vec2 partner = p.center_px + ((is_h ? 1.0 : -1.0) * D.separation_periods * p.period_px) * h_to_v;
  const double r = 2.0 * p.period_px;
  const bool outside = partner.x - r < 0 || partner.y - r < 0 || partner.x + r > cols - 1 || partner.y + r > rows - 1;
  e.partial = outside ? ChartElement::Partial::partner_out_of_view : ChartElement::Partial::partner_not_found;
  e.partial_reason = fmt::format("only the {} pattern was found; the {} pattern {}", is_h ? "horizontal-bar" : "vertical-bar",
                                 is_h ? "vertical-bar" : "horizontal-bar",
                                 outside ? "lies outside the image (the element is partly out of view)"
                                         : "is in the image but was not found there");
  return partner;
}

// The image direction from an H triplet to its V partner at the complete
// element found nearest to `at_px` (unit); none without one.
std::optional<Vec2> nearest_h_to_v(const ChartDetection& D, Vec2 at_px) {
  const ChartElement* near = nullptr;
  double near_d = 1e300;
  for (const ChartElement& e : D.elements) {
    if (e.h < 0 || e.v < 0 || D.patterns[e.h].predicted || D.patterns[e.v].predicted) continue;
    const double d = norm(D.patterns[e.h].center_px - at_px);
    if (d < near_d) near_d = d, near = &e;
  }
  if (!near) return std::nullopt;
  const Vec2 d = D.patterns[near->v].center_px - D.patterns[near->h].center_px;
  return (1.0 / norm(d)) * d;
}

// A lone pattern found where partial element e's missing partner stands
// (`partner_px`): bars within kLoneAxisTolerance of a quarter turn from the
// found pattern's, its centre within kJoinReachPeriods of the place, a
// period of 4 px or more (as a partial element's) and within kJoinPeriodLn
// (natural log) of the partner's predicted one; the nearest such, not a
// pattern of any element; -1 if none. The pairing's own period tolerance
// (0.15) is tighter: near a lit disc's rim (dev_12) a field's distortion
// squeezes one of an element's two patterns by 15 % (ln -0.16), and the
// pair is not made, though each was found. 0.2 is under two steps of the
// series, so that where the place is right the pattern is this element's.
constexpr double kJoinReachPeriods = 0.5, kJoinPeriodLn = 0.2;
int lone_partner(const ChartDetection& D, const ChartElement& e, Vec2 partner_px, const std::vector<int>& lone,
                 const std::vector<ChartElement>& partial) {
  const BarPattern& p = D.patterns[e.h >= 0 ? e.h : e.v];
  const double expected_period_px = (e.h >= 0 ? 1 / D.hv_period_ratio : D.hv_period_ratio) * p.period_px;
  const auto used = [&](int k) {
    const auto holds = [k](const ChartElement& x) { return x.h == k || x.v == k; };
    return std::any_of(D.elements.begin(), D.elements.end(), holds) ||
           std::any_of(partial.begin(), partial.end(), holds);
  };
  int best = -1;
  double best_d = kJoinReachPeriods * p.period_px;
  for (int k : lone) {
    const BarPattern& q = D.patterns[k];
    if (q.predicted || q.period_px < 4 || std::abs(dot(q.bar_dir, p.bar_dir)) > std::sin(kLoneAxisTolerance)) continue;
    if (std::abs(std::log(q.period_px / expected_period_px)) > kJoinPeriodLn || used(k)) continue;
    const double d = norm(q.center_px - partner_px);
    if (d < best_d) best_d = d, best = k;
  }
  return best;
}

// The found pattern of partial element `e` turned a quarter about itself
// and moved to `center_px`: its partner as the chart draws it, predicted,
// its period scaled by the chart's foreshortening (hv_period_ratio).
BarPattern predicted_partner(const ChartDetection& D, const ChartElement& e, Vec2 center_px) {
  const BarPattern& p = D.patterns[e.h >= 0 ? e.h : e.v];
  const double scale = e.h >= 0 ? 1 / D.hv_period_ratio : D.hv_period_ratio;
  BarPattern q = p;
  q.center_px = center_px;
  q.bar_dir = perp(p.bar_dir);
  q.period_px = scale * p.period_px;
  for (size_t i = 0; i < q.bar_centers_px.size(); ++i)
    q.bar_centers_px[i] = center_px + scale * perp(p.bar_centers_px[i] - p.center_px);
  q.predicted = true;
  q.nested = false;
  return q;
}

}  // namespace

// Partial elements (ChartElement::partial): a lone, well-sampled pattern
// whose period falls on the series at an index no element holds. Its
// orientation on the chart follows from the nearest complete element
// (chart x runs from an H triplet to its V partner); its partner would
// stand D.separation_periods away along chart x. Group and element are
// left to number_partial_elements (the anchor may not be known yet).
std::vector<ChartElement> partial_elements(const ChartDetection& D, const std::vector<int>& lone,
                                           const ScaleField& field, const cv::Mat& img) {
  std::vector<ChartElement> partial;
  std::vector<int> taken;
  for (const ChartElement& e : D.elements) taken.push_back(e.relative_index);
  const double step = std::log(2.0) / 6;
  for (int k : lone) {
    const BarPattern& p = D.patterns[k];
    if (p.period_px < 4) continue;  // a fine pattern's binarised period is not reliable enough to index it
    const std::optional<Vec2> near_h_to_v = nearest_h_to_v(D, p.center_px);
    if (!near_h_to_v) continue;
    const Vec2 ex = *near_h_to_v;
    // A chart's patterns run along its axes: a lone one turned from both
    // (a blurred numeral's strokes: dev_04's "6" beside G5E6, 11 deg) is no
    // element. Those found on the development set lie within 6.5 deg of
    // the nearest element's axes, distortion included.
    const double along_x = std::min(std::abs(dot(p.bar_dir, ex)), 1.0);
    if (std::min(std::acos(along_x), std::asin(along_x)) > kLoneAxisTolerance) continue;
    const bool is_h = along_x > std::cos(30 * M_PI / 180);
    // An element's period is its two patterns' mean: on a foreshortened
    // chart (pH = r pV) a lone V pattern's is 2 / (1 + r) of it, a lone H
    // pattern's 2r / (1 + r) (a V triplet alone at H/V 0.84 was indexed one
    // step too coarse).
    const double r = D.hv_period_ratio;
    const double element_period_px = p.period_px * (is_h ? (1 + r) / (2 * r) : (1 + r) / 2);
    const double x = (field.level0 + dot(field.g, field.position(p.center_px)) - std::log(element_period_px)) / step;
    const int index = static_cast<int>(std::lround(x));
    if (std::abs(x - index) > 0.3 || index < -6 || std::count(taken.begin(), taken.end(), index)) continue;
    ChartElement e;
    (is_h ? e.h : e.v) = k;
    e.period_px = element_period_px;
    e.relative_index = index;
    place_partner(D, e, ex, img.cols, img.rows);
    taken.push_back(index);
    partial.push_back(e);
  }
  sort_by_index(partial);
  return partial;
}

// The partial elements that keep an index no element holds (a predicted
// one may have taken it since), numbered by the anchor. With the
// arrangement recognised, each missing partner is placed on the side the
// maker's style puts it (h_side: an element 1 or an odd group's element
// has its H triplet right of the V on real charts), not the side of the
// nearest complete element. A lone pattern found where the partner stands
// completes the element (ChartElement::partner_joined). Otherwise, with
// the arrangement recognised, a partner that lies in the image is a
// prediction like a column's end, no longer a guess: it joins its found
// pattern as an element and is measured there (dev_02's G7E1 H, too faint
// beside its V triplet to binarise). A partner out of view stays partial.
void number_partial_elements(ChartDetection& D, std::vector<ChartElement> partial, const std::vector<int>& lone,
                             int cols, int rows) {
  std::erase_if(partial, [&](const ChartElement& p) {
    return std::any_of(D.elements.begin(), D.elements.end(),
                       [&](const ChartElement& e) { return e.relative_index == p.relative_index; });
  });
  const ChartDetection::Arrangement& A = D.arrangement;
  std::vector<ChartElement> still_partial;
  for (ChartElement& e : partial) {
    const int n = D.largest_index + e.relative_index;
    e.group = floor_div6(n);
    e.element = n - 6 * e.group + 1;
    const BarPattern& found = D.patterns[e.h >= 0 ? e.h : e.v];
    const std::optional<Vec2> h_to_v =
        A.recognised ? std::optional<Vec2>(double(h_side(e.relative_index + A.phase, A.generated_style)) * chart_x_px(A))
                     : nearest_h_to_v(D, found.center_px);
    if (!h_to_v) {
      still_partial.push_back(e);
      continue;
    }
    const Vec2 partner_px = place_partner(D, e, *h_to_v, cols, rows);
    const int joined = e.partial == ChartElement::Partial::partner_not_found ? lone_partner(D, e, partner_px, lone, partial) : -1;
    if (joined < 0 && (!A.recognised || e.partial != ChartElement::Partial::partner_not_found)) {
      still_partial.push_back(e);
      continue;
    }
    if (joined >= 0) {
      (e.h >= 0 ? e.v : e.h) = joined;
      e.partner_joined = true;
    } else {
      D.patterns.push_back(predicted_partner(D, e, partner_px));
      (e.h >= 0 ? e.v : e.h) = static_cast<int>(D.patterns.size()) - 1;
      ++D.partners_placed;
    }
    e.partial = ChartElement::Partial::no;
    e.partial_reason.clear();
    D.elements.push_back(e);
  }
  sort_by_index(D.elements);
  D.partial = std::move(still_partial);
}

}  // namespace tactres::locate_detail
