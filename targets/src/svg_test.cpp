#include <map>
#include <string>
#include <vector>

#include <doctest/doctest.h>

#include "tactres/targets/svg.h"

using namespace tactres;

namespace {

struct Element {
  std::string name;
  std::map<std::string, std::string> attrs;
  int depth = 0;
};

// A minimal XML reader for what target_svg() emits: it checks that tags
// balance and returns every element with its attributes and nesting depth.
std::vector<Element> parse_xml(const std::string& s) {
  std::vector<Element> out;
  std::vector<std::string> open;
  size_t i = 0;
  while ((i = s.find('<', i)) != std::string::npos) {
    const size_t end = s.find('>', i);
    REQUIRE(end != std::string::npos);
    std::string tag = s.substr(i + 1, end - i - 1);
    i = end + 1;
    if (tag.starts_with("?")) continue;
    if (tag.starts_with("/")) {
      REQUIRE(!open.empty());
      REQUIRE(open.back() == tag.substr(1));
      open.pop_back();
      continue;
    }
    const bool self_closing = tag.ends_with("/");
    if (self_closing) tag.pop_back();
    Element e;
    e.depth = int(open.size());
    size_t k = tag.find_first_of(" \n");
    e.name = tag.substr(0, k);
    while (k != std::string::npos && (k = tag.find('=', k)) != std::string::npos) {
      const size_t name_begin = tag.rfind(' ', k) + 1;
      const size_t q0 = tag.find('"', k), q1 = tag.find('"', q0 + 1);
      REQUIRE(q1 != std::string::npos);
      e.attrs[tag.substr(name_begin, k - name_begin)] = tag.substr(q0 + 1, q1 - q0 - 1);
      k = q1 + 1;
    }
    if (!self_closing) open.push_back(e.name);
    out.push_back(e);
  }
  CHECK(open.empty());
  return out;
}

}  // namespace

TEST_CASE("svg: well formed, true millimetres, one element per artwork shape in order") {
  TargetLayout L = make_layout({});
  ArtworkShape tri;  // the layout has no polygons of its own
  tri.kind = ArtworkShape::Kind::polygon;
  tri.role = ArtworkShape::Role::label;
  tri.polygon_mm = {{1, 19}, {1.5, 19}, {1.25, 19.5}};
  L.artwork.push_back(tri);

  const auto els = parse_xml(target_svg(L));
  int roots = 0;
  for (const Element& e : els) roots += e.depth == 0;
  CHECK(roots == 1);
  REQUIRE(els.front().name == "svg");
  CHECK(els.front().attrs.at("width") == "20mm");
  CHECK(els.front().attrs.at("height") == "20mm");
  CHECK(els.front().attrs.at("viewBox") == "0 0 20 20");

  std::vector<const Element*> shapes;
  for (const Element& e : els) {
    if (e.name == "rect" && e.attrs.at("class") == "ground") {
      CHECK(e.attrs.at("fill") == "#ffffff");
      CHECK(e.attrs.at("width") == "20");
    } else if (e.name == "rect" || e.name == "circle" || e.name == "polygon") {
      shapes.push_back(&e);
    }
  }
  REQUIRE(shapes.size() == L.artwork.size());
  for (size_t i = 0; i < shapes.size(); ++i) {
    const ArtworkShape& a = L.artwork[i];
    const Element& e = *shapes[i];
    switch (a.kind) {
      case ArtworkShape::Kind::rect:
        REQUIRE(e.name == "rect");
        CHECK(std::stod(e.attrs.at("x")) == a.rect_mm.x0);  // exact round trip
        CHECK(std::stod(e.attrs.at("height")) == a.rect_mm.height_mm());
        break;
      case ArtworkShape::Kind::disc:
        REQUIRE(e.name == "circle");
        CHECK(std::stod(e.attrs.at("cx")) == a.center_mm.x);
        CHECK(std::stod(e.attrs.at("r")) == a.radius_mm);
        CHECK(e.attrs.at("class") == "fiducial");
        break;
      case ArtworkShape::Kind::polygon:
        REQUIRE(e.name == "polygon");
        CHECK(e.attrs.at("points") == "1,19 1.5,19 1.25,19.5");
        break;
    }
  }
}

TEST_CASE("svg: light bars on dark swaps the colours") {
  LayoutOptions o;
  o.polarity = Polarity::light_bars_on_dark;
  o.field_width_mm = 24.5;
  const std::string s = target_svg(make_layout(o));
  CHECK(s.find("width=\"24.5mm\"") != std::string::npos);
  CHECK(s.find("class=\"ground\" x=\"0\" y=\"0\" width=\"24.5\" height=\"20\" fill=\"#000000\"") !=
        std::string::npos);
  CHECK(s.find("<g fill=\"#ffffff\"") != std::string::npos);
}
