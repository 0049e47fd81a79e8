#include "tactres/targets/mil_std_chart.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include <fmt/format.h>

#include "tactres/targets/glyphs.h"
#include "tactres/targets/usaf_series.h"

namespace tactres {

void MilStdChartOptions::validate() const {
  validate_group_range(first_group, last_group);
  validate_relief(relief_height_mm, base_thickness_mm);
}

namespace {

using namespace mil_std;

// Pair geometry in units of W (bar width of the pair's even group, element 1).
constexpr double kLabelBand = 2.5;   // group numbers: y in [0, 2.5]
constexpr double kColumnTop = 4.0;
constexpr double kPairWidth = 40.0;
constexpr double kMargin = 2.0;

double series_width(int k) { return std::exp2(-k / 6.0); }  // w of element k+1 relative to element 1

void add_rect(TargetLayout& L, ArtworkShape::Role role, const RectMm& r) {
  L.artwork.push_back({ArtworkShape::Kind::rect, role, r, {}, 0, {}});
}

void add_text(TargetLayout& L, const std::string& text, Vec2 origin, double height_mm) {
  const double w = 0.6 * height_mm, t = 0.2 * height_mm, gap = 0.3 * height_mm;
  std::vector<RectMm> rects;
  double x = origin.x;
  for (char c : text) {
    append_glyph(c, {x, origin.y}, w, height_mm, t, rects);
    x += w + gap;
  }
  for (const RectMm& r : rects) add_rect(L, ArtworkShape::Role::label, r);
}

// One element with its block's top-left corner at `o` (mm).
void add_element(TargetLayout& L, int group, int element, Vec2 o) {
  const double w = usaf_bar_width_mm(group, element);
  add_text(L, std::to_string(element), {o.x, o.y + 0.5 * w}, kDigitHeight * w);
  ElementLayout h, v;
  for (ElementLayout* e : {&h, &v}) {
    e->group = group;
    e->element = element;
    e->lp_per_mm = usaf_lp_per_mm(group, element);
    e->bar_width_mm = w;
  }
  h.orientation = BarOrientation::horizontal_bars;
  v.orientation = BarOrientation::vertical_bars;
  const double hx = o.x + kHX * w, vx = o.x + kVX * w;
  for (int i = 0; i < 3; ++i) {
    h.bars_mm[i] = {hx, o.y + 2 * i * w, hx + 5 * w, o.y + (2 * i + 1) * w};
    v.bars_mm[i] = {vx + 2 * i * w, o.y, vx + (2 * i + 1) * w, o.y + 5 * w};
  }
  for (const ElementLayout* e : {&h, &v}) {
    for (const RectMm& r : e->bars_mm) add_rect(L, ArtworkShape::Role::bar, r);
    L.elements.push_back(*e);
  }
}

bool in_range(const MilStdChartOptions& o, int g) { return g >= o.first_group && g <= o.last_group; }

// Places the pair (g, g+1) with its top-left corner at `o`; W is the bar
// width of g.1 in mm. Recurses into the next pair.
void add_pair(TargetLayout& L, const MilStdChartOptions& opt, int g, Vec2 o, double W, bool outermost) {
  if (g > opt.last_group) return;
  const double right = o.x + kPairWidth * W;
  // Even group: elements 2..6 down the left side, element 1 at the lower right.
  if (in_range(opt, g)) {
    add_text(L, std::to_string(g), {o.x, o.y}, kLabelBand * W);
    double y = o.y + kColumnTop * W;
    for (int e = 2; e <= kUsafElementsPerGroup; ++e) {
      const double w = W * series_width(e - 1);
      add_element(L, g, e, {o.x, y});
      y += (5 + kColumnGap) * w;
    }
  }
  // Odd group: elements 1..6 down the right side from the upper right.
  const double odd_x = right - kBlockWidth * 0.5 * W;
  double y = o.y + kColumnTop * W;
  if (in_range(opt, g + 1)) {
    add_text(L, std::to_string(g + 1), {odd_x, o.y}, 0.5 * kLabelBand * W);
    for (int e = 1; e <= kUsafElementsPerGroup; ++e) {
      const double w = 0.5 * W * series_width(e - 1);
      add_element(L, g + 1, e, {odd_x, y});
      y += (5 + kColumnGap) * w;
    }
  } else {
    y += (5 + kColumnGap) * 0.5 * W * (1 + series_width(1) + series_width(2) + series_width(3) +
                                       series_width(4) + series_width(5));
  }
  // g.1 (bar width W) keeps its own column gap below the odd column.
  const double last_gap = kColumnGap * 0.5 * W * series_width(5);
  const double e1_y = y - last_gap + kColumnGap * W;
  if (in_range(opt, g)) add_element(L, g, 1, {right - kBlockWidth * W, e1_y});
  // The large square: lower middle of the outermost pair, level with g.1.
  if (outermost) {
    const double x0 = o.x + 16.6 * W;
    L.reference_patch_mm = {x0, e1_y, x0 + kSquareSide * W, e1_y + kSquareSide * W};
    add_rect(L, ArtworkShape::Role::patch, L.reference_patch_mm);
  }
  // The next pair, 4 times smaller, centred in the space between the columns
  // above g.1: x in [16.6, 29.8] W, y in [kColumnTop, e1 - 2] W.
  const double inner_W = W / 4;
  const double region_x0 = o.x + 16.6 * W, region_x1 = odd_x - 2 * W;
  const double region_y0 = o.y + kColumnTop * W, region_y1 = e1_y - 2 * W;
  const double inner_w = kPairWidth * inner_W, inner_h = 30.0 * inner_W;
  add_pair(L, opt, g + 2,
           {region_x0 + 0.5 * (region_x1 - region_x0 - inner_w), region_y0 + 0.5 * (region_y1 - region_y0 - inner_h)},
           inner_W, false);
}

}  // namespace

TargetLayout make_mil_std_chart(const MilStdChartOptions& options) {
  options.validate();
  TargetLayout L;
  L.polarity = options.polarity;
  L.relief_height_mm = options.relief_height_mm;
  L.base_thickness_mm = options.base_thickness_mm;
  L.first_group = options.first_group;
  L.last_group = options.last_group;
  // Pairs start at an even group; an odd first group leaves the even half empty.
  const int g0 = options.first_group - (((options.first_group % 2) + 2) % 2);
  const double W = usaf_bar_width_mm(g0, 1);
  add_pair(L, options, g0, {kMargin * W, kMargin * W}, W, true);

  // Size: the bounding box of the artwork plus the margin.
  double x1 = 0, y1 = 0;
  for (const ArtworkShape& s : L.artwork) {
    x1 = std::max(x1, s.bounds_mm().x1);
    y1 = std::max(y1, s.bounds_mm().y1);
  }
  L.width_mm = x1 + kMargin * W;
  L.height_mm = y1 + kMargin * W;
  // Elements in reading order: coarse to fine, horizontal before vertical.
  std::stable_sort(L.elements.begin(), L.elements.end(), [](const ElementLayout& a, const ElementLayout& b) {
    return std::tuple(a.group, a.element, a.orientation) < std::tuple(b.group, b.element, b.orientation);
  });
  return L;
}

}  // namespace tactres
