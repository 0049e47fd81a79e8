#include "tactres/targets/layout.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>

#include <fmt/format.h>

#include "tactres/targets/glyphs.h"
#include "tactres/targets/usaf_series.h"

namespace tactres {

const char* to_string(BarOrientation o) {
  return o == BarOrientation::horizontal_bars ? "horizontal_bars" : "vertical_bars";
}
const char* to_string(Polarity p) {
  return p == Polarity::dark_bars_on_light ? "dark_bars_on_light" : "light_bars_on_dark";
}
BarOrientation bar_orientation_from_string(const std::string& s) {
  if (s == "horizontal_bars") return BarOrientation::horizontal_bars;
  if (s == "vertical_bars") return BarOrientation::vertical_bars;
  throw std::invalid_argument("unknown orientation '" + s +
                              "': valid are horizontal_bars, vertical_bars");
}
Polarity polarity_from_string(const std::string& s) {
  if (s == "dark_bars_on_light") return Polarity::dark_bars_on_light;
  if (s == "light_bars_on_dark") return Polarity::light_bars_on_dark;
  throw std::invalid_argument("unknown polarity '" + s +
                              "': valid are dark_bars_on_light, light_bars_on_dark");
}

RectMm ArtworkShape::bounds_mm() const {
  switch (kind) {
    case Kind::rect: return rect_mm;
    case Kind::disc:
      return {center_mm.x - radius_mm, center_mm.y - radius_mm, center_mm.x + radius_mm,
              center_mm.y + radius_mm};
    case Kind::polygon: {
      RectMm b{1e300, 1e300, -1e300, -1e300};
      for (const Vec2& p : polygon_mm) b = bounding_union(b, {p.x, p.y, p.x, p.y});
      return b;
    }
  }
  return {};
}

double ArtworkShape::area_mm2() const {
  switch (kind) {
    case Kind::rect: return rect_mm.area_mm2();
    case Kind::disc: return std::numbers::pi * radius_mm * radius_mm;
    case Kind::polygon: {
      double twice = 0.0;  // shoelace formula
      for (size_t i = 0; i < polygon_mm.size(); ++i)
        twice += cross(polygon_mm[i], polygon_mm[(i + 1) % polygon_mm.size()]);
      return 0.5 * std::abs(twice);
    }
  }
  return 0.0;
}

double TargetLayout::inked_area_mm2() const {
  double sum = 0.0;
  for (const auto& s : artwork) sum += s.area_mm2();
  return sum;
}

const ElementLayout* TargetLayout::find(int group, int element, BarOrientation o) const {
  for (const auto& e : elements)
    if (e.group == group && e.element == element && e.orientation == o) return &e;
  return nullptr;
}

namespace {
bool in_range(double v, double hi) { return std::isfinite(v) && v > 0 && v <= hi; }
}  // namespace

void validate_group_range(int first_group, int last_group) {
  if (last_group < first_group)
    throw std::invalid_argument(fmt::format(
        "the group range {}..{} is empty or inverted: --last-group must be >= --first-group",
        first_group, last_group));
  if (first_group < -10 || last_group > 12)
    throw std::invalid_argument(fmt::format(
        "groups must lie in -10..12 (bar widths 512 mm .. 0.06 um), got {}..{}", first_group,
        last_group));
}

void validate_relief(double relief_height_mm, double base_thickness_mm) {
  if (!in_range(relief_height_mm, 10))
    throw std::invalid_argument(
        fmt::format("relief height must be in (0, 10] mm (--relief-um in (0, 10000]), got {} mm",
                    relief_height_mm));
  if (!in_range(base_thickness_mm, 100))
    throw std::invalid_argument(
        fmt::format("base thickness must be in (0, 100] mm, got {} mm", base_thickness_mm));
}

void LayoutOptions::validate() const {
  validate_group_range(first_group, last_group);
  if (!in_range(field_width_mm, 1000) || !in_range(field_height_mm, 1000))
    throw std::invalid_argument(fmt::format(
        "field size must be in (0, 1000] mm on each side, got {} x {} mm", field_width_mm,
        field_height_mm));
  if (std::min(field_width_mm, field_height_mm) < 5.0)
    throw std::invalid_argument(fmt::format(
        "field {} x {} mm is too small for fiducials and a reference patch: use at least 5 mm "
        "per side",
        field_width_mm, field_height_mm));
  validate_relief(relief_height_mm, base_thickness_mm);
}

// Declared in glyphs.h (shared with the MIL-STD-150A chart).
void append_glyph(char c, Vec2 origin, double w, double h, double t, std::vector<RectMm>& out) {
  const double mid0 = 0.5 * (h - t), mid1 = 0.5 * (h + t);
  const RectMm a{0, 0, w, t}, g{0, mid0, w, mid1}, d{0, h - t, w, h};
  const RectMm f{0, t, t, mid0}, b{w - t, t, w, mid0};
  const RectMm e{0, mid1, t, h - t}, cc{w - t, mid1, w, h - t};
  // Bits: a b c d e f g.
  static constexpr unsigned char kDigits[10] = {0x7E, 0x30, 0x6D, 0x79, 0x33,
                                                0x5B, 0x5F, 0x70, 0x7F, 0x7B};
  std::vector<RectMm> segs;
  if (c >= '0' && c <= '9') {
    const unsigned bits = kDigits[c - '0'];
    const RectMm all[7] = {a, b, cc, d, e, f, g};
    for (int i = 0; i < 7; ++i)
      if (bits & (0x40u >> i)) segs.push_back(all[i]);
  } else if (c == '-') {
    segs.push_back(g);
  } else if (c == '.') {
    segs.push_back({0, h - t, t, h});
  }
  for (const RectMm& r : segs) out.push_back(r.translated(origin));
}

namespace {

double glyph_width(char c, double digit_w, double t) { return c == '.' ? t : digit_w; }

// A packable block: its padded size and a function of its top-left corner.
struct Block {
  double width_mm = 0, height_mm = 0;
  int group = 0, element = 0;  // element == 0 marks the reference patch
  double bar_width_mm = 0;
};

struct Placement {
  Block block;
  Vec2 origin_mm;
};

// Element block, x: pad | label | w | H triplet 5w | 3w | V triplet 5w | pad.
// The 3w gap keeps the blurred ends of the H bars out of the V triplet's
// profile window (which reaches 1.5w beyond its outer bars).
struct ElementGeometry {
  double w, pad, label_h, digit_w, stroke, glyph_gap;
  std::string text;
  double label_width() const {
    double x = 0;
    for (size_t i = 0; i < text.size(); ++i)
      x += glyph_width(text[i], digit_w, stroke) + (i + 1 < text.size() ? glyph_gap : 0);
    return x;
  }
};

ElementGeometry element_geometry(int group, int element) {
  const double w = usaf_bar_width_mm(group, element);
  return {w, kQuietZoneBarWidths * w, 2.5 * w, 1.5 * w, 0.35 * w, 0.5 * w,
          fmt::format("{}.{}", group, element)};
}

Block element_block(int group, int element) {
  const ElementGeometry g = element_geometry(group, element);
  return {2 * g.pad + g.label_width() + g.w + 13 * g.w, 2 * g.pad + 5 * g.w, group, element, g.w};
}

void place_element(const Placement& p, TargetLayout& layout) {
  const ElementGeometry g = element_geometry(p.block.group, p.block.element);
  const double w = g.w;
  const Vec2 o = p.origin_mm;
  const double top = o.y + g.pad;
  const double label_x = o.x + g.pad;
  const double h_x = label_x + g.label_width() + w;
  const double v_x = h_x + 8 * w;

  // Label, vertically centred on the triplets.
  std::vector<RectMm> glyph_rects;
  double x = label_x;
  for (char c : g.text) {
    append_glyph(c, {x, top + 0.5 * (5 * w - g.label_h)}, g.digit_w, g.label_h, g.stroke,
                 glyph_rects);
    x += glyph_width(c, g.digit_w, g.stroke) + g.glyph_gap;
  }
  for (const RectMm& r : glyph_rects)
    layout.artwork.push_back({ArtworkShape::Kind::rect, ArtworkShape::Role::label, r, {}, 0, {}});

  ElementLayout h, v;
  for (ElementLayout* el : {&h, &v}) {
    el->group = p.block.group;
    el->element = p.block.element;
    el->lp_per_mm = usaf_lp_per_mm(el->group, el->element);
    el->bar_width_mm = w;
  }
  h.orientation = BarOrientation::horizontal_bars;
  v.orientation = BarOrientation::vertical_bars;
  for (int i = 0; i < 3; ++i) {
    h.bars_mm[i] = {h_x, top + 2 * i * w, h_x + 5 * w, top + (2 * i + 1) * w};
    v.bars_mm[i] = {v_x + 2 * i * w, top, v_x + (2 * i + 1) * w, top + 5 * w};
  }
  for (const ElementLayout* el : {&h, &v}) {
    for (const RectMm& r : el->bars_mm)
      layout.artwork.push_back({ArtworkShape::Kind::rect, ArtworkShape::Role::bar, r, {}, 0, {}});
    layout.elements.push_back(*el);
  }
}

// First-fit decreasing-height shelf packing into `area`. Returns nullopt if
// the blocks do not fit.
std::optional<std::vector<Placement>> pack_shelves(std::vector<Block> blocks, RectMm area) {
  std::stable_sort(blocks.begin(), blocks.end(),
                   [](const Block& a, const Block& b) { return a.height_mm > b.height_mm; });
  struct Shelf {
    double y, height, x_used;
  };
  std::vector<Shelf> shelves;
  std::vector<Placement> placed;
  double bottom = area.y0;
  for (const Block& b : blocks) {
    if (b.width_mm > area.width_mm()) return std::nullopt;
    Shelf* fit = nullptr;
    for (Shelf& s : shelves)
      if (b.height_mm <= s.height && s.x_used + b.width_mm <= area.width_mm()) {
        fit = &s;
        break;
      }
    if (!fit) {
      if (bottom + b.height_mm > area.y1) return std::nullopt;
      shelves.push_back({bottom, b.height_mm, 0.0});
      bottom += b.height_mm;
      fit = &shelves.back();
    }
    placed.push_back({b, {area.x0 + fit->x_used, fit->y}});
    fit->x_used += b.width_mm;
  }
  // Centre the packing in the area: it reads better and keeps margins even.
  double used_w = 0;
  for (const Shelf& s : shelves) used_w = std::max(used_w, s.x_used);
  const Vec2 shift{0.5 * (area.width_mm() - used_w), 0.5 * (area.y1 - bottom)};
  for (Placement& p : placed) p.origin_mm = p.origin_mm + shift;
  return placed;
}

std::optional<TargetLayout> try_make_layout(const LayoutOptions& o) {
  TargetLayout layout;
  layout.width_mm = o.field_width_mm;
  layout.height_mm = o.field_height_mm;
  layout.polarity = o.polarity;
  layout.relief_height_mm = o.relief_height_mm;
  layout.base_thickness_mm = o.base_thickness_mm;
  layout.first_group = o.first_group;
  layout.last_group = o.last_group;

  const double side = std::min(o.field_width_mm, o.field_height_mm);
  const double edge = std::max(0.2, 0.02 * side);
  const double r = std::clamp(0.03 * side, 0.25, 1.0);
  const double c = edge + r;
  const double W = o.field_width_mm, H = o.field_height_mm;
  // Five discs: four corners and one on the top edge a third of the way from
  // TL to TR. The collinear top triple with its off-centre member fixes which
  // edge is the top and which end is left, so mirrored views are told apart.
  layout.fiducials = {{"TL", {c, c}, r},         {"T3", {c + (W - 2 * c) / 3.0, c}, r},
                      {"TR", {W - c, c}, r},     {"BL", {c, H - c}, r},
                      {"BR", {W - c, H - c}, r}};
  for (const Fiducial& f : layout.fiducials)
    layout.artwork.push_back(
        {ArtworkShape::Kind::disc, ArtworkShape::Role::fiducial, {}, f.center_mm, f.radius_mm, {}});

  const double widest_bar_mm = usaf_bar_width_mm(o.first_group, 1);
  const double patch_mm = std::clamp(0.15 * side, 1.0, 6.0);
  std::vector<Block> blocks;
  blocks.push_back({patch_mm + 2 * widest_bar_mm, patch_mm + 2 * widest_bar_mm, 0, 0, widest_bar_mm});
  for (int g = o.first_group; g <= o.last_group; ++g)
    for (int e = 1; e <= kUsafElementsPerGroup; ++e) blocks.push_back(element_block(g, e));

  const RectMm area{edge, c + r + 0.2, W - edge, H - (c + r + 0.2)};
  const auto placed = pack_shelves(blocks, area);
  if (!placed) return std::nullopt;

  for (const Placement& p : *placed) {
    if (p.block.element == 0) {
      const double pad = p.block.bar_width_mm;
      layout.reference_patch_mm = {p.origin_mm.x + pad, p.origin_mm.y + pad,
                                   p.origin_mm.x + pad + patch_mm, p.origin_mm.y + pad + patch_mm};
      layout.artwork.push_back({ArtworkShape::Kind::rect, ArtworkShape::Role::patch,
                                layout.reference_patch_mm, {}, 0, {}});
    }
  }
  // Elements in reading order: coarse to fine, horizontal before vertical.
  std::vector<Placement> elements;
  for (const Placement& p : *placed)
    if (p.block.element != 0) elements.push_back(p);
  std::sort(elements.begin(), elements.end(), [](const Placement& a, const Placement& b) {
    return std::pair(a.block.group, a.block.element) < std::pair(b.block.group, b.block.element);
  });
  for (const Placement& p : elements) place_element(p, layout);
  return layout;
}

}  // namespace

TargetLayout make_layout(const LayoutOptions& options) {
  options.validate();
  if (auto layout = try_make_layout(options)) return *layout;

  // Say what would fit: fewer groups in this field, or a bigger field.
  std::string fewer = "no group fits this field";
  for (int last = options.last_group - 1; last >= options.first_group; --last) {
    LayoutOptions o = options;
    o.last_group = last;
    if (try_make_layout(o)) {
      fewer = fmt::format("groups {}..{} fit this field", options.first_group, last);
      break;
    }
  }
  std::string bigger;
  for (double scale = 1.05; scale < 50; scale *= 1.05) {
    LayoutOptions o = options;
    o.field_width_mm = std::ceil(options.field_width_mm * scale);
    o.field_height_mm = std::ceil(options.field_height_mm * scale);
    if (try_make_layout(o)) {
      bigger = fmt::format("a field of {:g} x {:g} mm holds groups {}..{}", o.field_width_mm,
                           o.field_height_mm, options.first_group, options.last_group);
      break;
    }
  }
  throw std::invalid_argument(fmt::format(
      "groups {}..{} do not fit a {:g} x {:g} mm field: {}{}{}", options.first_group,
      options.last_group, options.field_width_mm, options.field_height_mm, fewer,
      bigger.empty() ? "" : "; ", bigger));
}

}  // namespace tactres
