#include "tactres/targets/layout_json.h"

#include <cmath>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "tactres/targets/usaf_series.h"
#include "tactres/util/atomic_file.h"
#include "tactres/util/json_fields.h"

namespace tactres {

using nlohmann::json;

namespace {

json rect_json(const RectMm& r) { return json::array({r.x0, r.y0, r.x1, r.y1}); }
json vec_json(Vec2 v) { return json::array({v.x, v.y}); }

const char* to_string(ArtworkShape::Role r) {
  switch (r) {
    case ArtworkShape::Role::bar: return "bar";
    case ArtworkShape::Role::patch: return "patch";
    case ArtworkShape::Role::fiducial: return "fiducial";
    case ArtworkShape::Role::label: return "label";
  }
  return "bar";
}

// Field access with messages that name the field.
const json& field(const json& j, const char* key, const std::string& where) {
  if (!j.is_object()) throw std::invalid_argument(where + " must be a JSON object");
  auto it = j.find(key);
  if (it == j.end()) throw std::invalid_argument(fmt::format("{} lacks the field \"{}\"", where, key));
  return *it;
}

double number(const json& j, const std::string& where) {
  if (!j.is_number()) throw std::invalid_argument(where + " must be a number");
  const double v = j.get<double>();
  if (!std::isfinite(v)) throw std::invalid_argument(where + " must be finite");
  return v;
}

double number_field(const json& j, const char* key, const std::string& where) {
  return number(field(j, key, where), where + "." + key);
}

int int_field(const json& j, const char* key, const std::string& where) {
  const json& v = field(j, key, where);
  if (!v.is_number_integer())
    throw std::invalid_argument(fmt::format("{}.{} must be an integer", where, key));
  return v.get<int>();
}

std::string string_field(const json& j, const char* key, const std::string& where) {
  const json& v = field(j, key, where);
  if (!v.is_string()) throw std::invalid_argument(fmt::format("{}.{} must be a string", where, key));
  return v.get<std::string>();
}

Vec2 vec_from(const json& j, const std::string& where) {
  if (!j.is_array() || j.size() != 2) throw std::invalid_argument(where + " must be [x, y] in mm");
  return {number(j[0], where + "[0]"), number(j[1], where + "[1]")};
}

RectMm rect_from(const json& j, const std::string& where) {
  if (!j.is_array() || j.size() != 4)
    throw std::invalid_argument(where + " must be [x0, y0, x1, y1] in mm");
  RectMm r{number(j[0], where), number(j[1], where), number(j[2], where), number(j[3], where)};
  if (!(r.x0 < r.x1 && r.y0 < r.y1))
    throw std::invalid_argument(where + " must have x0 < x1 and y0 < y1");
  return r;
}

ArtworkShape::Role role_from(const json& j, const std::string& where) {
  if (!j.contains("role")) return ArtworkShape::Role::bar;  // optional: other producers
  const std::string s = string_field(j, "role", where);
  if (s == "bar") return ArtworkShape::Role::bar;
  if (s == "patch") return ArtworkShape::Role::patch;
  if (s == "fiducial") return ArtworkShape::Role::fiducial;
  if (s == "label") return ArtworkShape::Role::label;
  throw std::invalid_argument(where + ".role '" + s + "' is not one of bar, patch, fiducial, label");
}

}  // namespace

json layout_to_json(const TargetLayout& layout) {
  json j;
  j["schema"] = kLayoutSchema;
  j["units"] = "mm";
  j["size_mm"] = json::array({layout.width_mm, layout.height_mm});
  j["polarity"] = to_string(layout.polarity);
  j["relief_height_mm"] = layout.relief_height_mm;
  j["base_thickness_mm"] = layout.base_thickness_mm;
  j["groups"] = json::array({layout.first_group, layout.last_group});
  json elements = json::array();
  for (const ElementLayout& e : layout.elements) {
    json bars = json::array();
    for (const RectMm& r : e.bars_mm) bars.push_back(rect_json(r));
    elements.push_back({{"group", e.group},
                        {"element", e.element},
                        {"lp_per_mm", e.lp_per_mm},
                        {"bar_width_mm", e.bar_width_mm},
                        {"orientation", to_string(e.orientation)},
                        {"bars_mm", bars}});
  }
  j["elements"] = elements;
  j["reference_patch_mm"] = rect_json(layout.reference_patch_mm);
  json fids = json::array();
  for (const Fiducial& f : layout.fiducials)
    fids.push_back({{"kind", "disc"},
                    {"id", f.id},
                    {"center_mm", vec_json(f.center_mm)},
                    {"radius_mm", f.radius_mm}});
  j["fiducials"] = fids;
  json art = json::array();
  for (const ArtworkShape& s : layout.artwork) {
    json a;
    switch (s.kind) {
      case ArtworkShape::Kind::rect:
        a = {{"kind", "rect"}, {"mm", rect_json(s.rect_mm)}};
        break;
      case ArtworkShape::Kind::disc:
        a = {{"kind", "disc"}, {"center_mm", vec_json(s.center_mm)}, {"radius_mm", s.radius_mm}};
        break;
      case ArtworkShape::Kind::polygon: {
        json pts = json::array();
        for (Vec2 p : s.polygon_mm) pts.push_back(vec_json(p));
        a = {{"kind", "polygon"}, {"mm", pts}};
        break;
      }
    }
    a["role"] = to_string(s.role);
    art.push_back(a);
  }
  j["artwork"] = art;
  return j;
}

namespace {

// An element's numbers must agree with each other and with its bars: a
// layout edited by hand (lp_per_mm 3 beside bar_width_mm 0.5) would be
// measured and reported under a frequency its bars do not have.
void check_element(const ElementLayout& e, const TargetLayout& L, const std::string& where) {
  const double series = usaf_lp_per_mm(e.group, e.element);
  if (std::abs(e.lp_per_mm / series - 1) > 1e-3)
    throw std::invalid_argument(fmt::format("{}.lp_per_mm {:g} is not group {} element {}'s {:.4g} lp/mm "
                                            "(2^(group + (element - 1) / 6)): regenerate the layout",
                                            where, e.lp_per_mm, e.group, e.element, series));
  if (std::abs(e.bar_width_mm * 2 * e.lp_per_mm - 1) > 1e-3)
    throw std::invalid_argument(fmt::format("{}.bar_width_mm {:g} is not half a line pair at {:g} lp/mm ({:g} mm)",
                                            where, e.bar_width_mm, e.lp_per_mm, 0.5 / e.lp_per_mm));
  for (int b = 0; b < 3; ++b) {
    const RectMm& r = e.bars_mm[b];
    const double narrow = std::min(r.x1 - r.x0, r.y1 - r.y0);
    if (std::abs(narrow / e.bar_width_mm - 1) > 0.01)
      throw std::invalid_argument(fmt::format("{}.bars_mm[{}] is {:g} mm wide, not the element's bar width {:g} mm",
                                              where, b, narrow, e.bar_width_mm));
    const double slack = 1e-6 * std::max(L.width_mm, L.height_mm);
    if (r.x0 < -slack || r.y0 < -slack || r.x1 > L.width_mm + slack || r.y1 > L.height_mm + slack)
      throw std::invalid_argument(fmt::format("{}.bars_mm[{}] lies outside the target's size_mm [{:g}, {:g}]", where,
                                              b, L.width_mm, L.height_mm));
  }
}

}  // namespace

TargetLayout layout_from_json(const json& j) {
  const std::string top = "layout";
  const std::string schema = string_field(j, "schema", top);
  if (schema != kLayoutSchema)
    throw std::invalid_argument(fmt::format(
        "layout schema is \"{}\", expected \"{}\": regenerate it with `tactres generate`", schema,
        kLayoutSchema));
  if (string_field(j, "units", top) != "mm")
    throw std::invalid_argument("layout.units must be \"mm\"");

  reject_unknown_fields(j,
                        {"schema", "units", "size_mm", "polarity", "relief_height_mm", "base_thickness_mm", "groups",
                         "elements", "reference_patch_mm", "fiducials", "artwork"},
                        top);
  TargetLayout L;
  const Vec2 size = vec_from(field(j, "size_mm", top), "layout.size_mm");
  L.width_mm = size.x;
  L.height_mm = size.y;
  if (!(L.width_mm > 0 && L.height_mm > 0))
    throw std::invalid_argument("layout.size_mm must be positive");
  L.polarity = polarity_from_string(string_field(j, "polarity", top));
  L.relief_height_mm = number_field(j, "relief_height_mm", top);
  if (!(L.relief_height_mm > 0)) throw std::invalid_argument("layout.relief_height_mm must be > 0");
  if (j.contains("base_thickness_mm")) L.base_thickness_mm = number_field(j, "base_thickness_mm", top);

  const json& els = field(j, "elements", top);
  if (!els.is_array() || els.empty())
    throw std::invalid_argument("layout.elements must be a non-empty array");
  int gmin = 1000, gmax = -1000;
  for (size_t i = 0; i < els.size(); ++i) {
    const std::string where = fmt::format("layout.elements[{}]", i);
    reject_unknown_fields(els[i], {"group", "element", "lp_per_mm", "bar_width_mm", "orientation", "bars_mm"}, where);
    ElementLayout e;
    e.group = int_field(els[i], "group", where);
    e.element = int_field(els[i], "element", where);
    if (e.element < 1 || e.element > 6) throw std::invalid_argument(where + ".element must be 1..6");
    e.lp_per_mm = number_field(els[i], "lp_per_mm", where);
    e.bar_width_mm = number_field(els[i], "bar_width_mm", where);
    if (!(e.lp_per_mm > 0 && e.bar_width_mm > 0))
      throw std::invalid_argument(where + ": lp_per_mm and bar_width_mm must be > 0");
    e.orientation = bar_orientation_from_string(string_field(els[i], "orientation", where));
    const json& bars = field(els[i], "bars_mm", where);
    if (!bars.is_array() || bars.size() != 3)
      throw std::invalid_argument(where + ".bars_mm must hold exactly 3 bars");
    for (int b = 0; b < 3; ++b) e.bars_mm[b] = rect_from(bars[b], fmt::format("{}.bars_mm[{}]", where, b));
    check_element(e, L, where);
    for (size_t k = 0; k < L.elements.size(); ++k)
      if (L.elements[k].group == e.group && L.elements[k].element == e.element &&
          L.elements[k].orientation == e.orientation)
        throw std::invalid_argument(fmt::format("{} repeats layout.elements[{}] (group {} element {}, {}): each "
                                                "element and orientation once",
                                                where, k, e.group, e.element, to_string(e.orientation)));
    gmin = std::min(gmin, e.group);
    gmax = std::max(gmax, e.group);
    L.elements.push_back(e);
  }
  L.first_group = gmin;
  L.last_group = gmax;
  validate_group_range(gmin, gmax);
  if (j.contains("groups")) {
    const Vec2 groups = vec_from(j["groups"], "layout.groups");
    if (groups.x != gmin || groups.y != gmax)
      throw std::invalid_argument(fmt::format("layout.groups [{:g}, {:g}] does not match its elements' groups {}..{}",
                                              groups.x, groups.y, gmin, gmax));
  }
  L.reference_patch_mm = rect_from(field(j, "reference_patch_mm", top), "layout.reference_patch_mm");

  const json& fids = field(j, "fiducials", top);
  if (!fids.is_array()) throw std::invalid_argument("layout.fiducials must be an array");
  for (size_t i = 0; i < fids.size(); ++i) {
    const std::string where = fmt::format("layout.fiducials[{}]", i);
    reject_unknown_fields(fids[i], {"kind", "id", "center_mm", "radius_mm"}, where);
    Fiducial f;
    if (string_field(fids[i], "kind", where) != "disc")
      throw std::invalid_argument(where + ".kind must be \"disc\"");
    f.id = fids[i].contains("id") ? string_field(fids[i], "id", where) : fmt::format("F{}", i);
    f.center_mm = vec_from(field(fids[i], "center_mm", where), where + ".center_mm");
    f.radius_mm = number_field(fids[i], "radius_mm", where);
    if (!(f.radius_mm > 0)) throw std::invalid_argument(where + ".radius_mm must be > 0");
    L.fiducials.push_back(f);
  }

  const json& art = field(j, "artwork", top);
  if (!art.is_array()) throw std::invalid_argument("layout.artwork must be an array");
  for (size_t i = 0; i < art.size(); ++i) {
    const std::string where = fmt::format("layout.artwork[{}]", i);
    reject_unknown_fields(art[i], {"kind", "role", "mm", "center_mm", "radius_mm"}, where);
    ArtworkShape s;
    s.role = role_from(art[i], where);
    const std::string kind = string_field(art[i], "kind", where);
    if (kind == "rect") {
      s.kind = ArtworkShape::Kind::rect;
      s.rect_mm = rect_from(field(art[i], "mm", where), where + ".mm");
    } else if (kind == "disc") {
      s.kind = ArtworkShape::Kind::disc;
      s.center_mm = vec_from(field(art[i], "center_mm", where), where + ".center_mm");
      s.radius_mm = number_field(art[i], "radius_mm", where);
      if (!(s.radius_mm > 0)) throw std::invalid_argument(where + ".radius_mm must be > 0");
    } else if (kind == "polygon") {
      s.kind = ArtworkShape::Kind::polygon;
      const json& pts = field(art[i], "mm", where);
      if (!pts.is_array() || pts.size() < 3)
        throw std::invalid_argument(where + ".mm must list at least 3 [x, y] points");
      for (size_t k = 0; k < pts.size(); ++k)
        s.polygon_mm.push_back(vec_from(pts[k], fmt::format("{}.mm[{}]", where, k)));
    } else {
      throw std::invalid_argument(where + ".kind '" + kind + "' is not one of rect, disc, polygon");
    }
    L.artwork.push_back(s);
  }
  return L;
}

json parse_json_text(const std::string& text, const std::string& what) {
  try {
    return json::parse(text);
  } catch (const json::parse_error& e) {
    throw std::invalid_argument(fmt::format(
        "{} is not valid JSON (byte {}): {}", what, e.byte, e.what()));
  } catch (const json::out_of_range& e) {  // a number beyond double's range, e.g. 1e400 (found by fuzzing)
    throw std::invalid_argument(fmt::format("{} is not valid JSON: {}", what, e.what()));
  }
}

TargetLayout read_layout_file(const std::filesystem::path& path) {
  const json j = parse_json_text(read_file(path), path.string());
  try {
    return layout_from_json(j);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(path.string() + ": " + e.what());
  }
}

void write_layout_file(const std::filesystem::path& path, const TargetLayout& layout) {
  write_file_atomically(path, json_text(layout_to_json(layout)) + "\n");
}

}  // namespace tactres
