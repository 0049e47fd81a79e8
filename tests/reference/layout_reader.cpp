// Reads a tactres.target/1 layout JSON on its own (no tactres code) and turns
// every artwork shape into disjoint axis-aligned rectangles, because a
// Gaussian-blurred rectangle has a closed form (a product of erf differences).
//
// Discs and polygons are decomposed into thin horizontal scanline strips:
// - a disc into `strips` strips of equal height, each as wide as the disc's
//   exact area between the strip's two scanlines (so the total area is exact);
// - a polygon into strips no taller than max_strip_mm, each spanning the
//   polygon's inside along the strip's mid line (even-odd rule).
// The strips are much thinner than the blur (sigma >= 0.02 mm in every test),
// so the blurred staircase equals the blurred shape to far better than the
// tests' tolerances; fiducials and labels are never measured anyway.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <stdexcept>

#include "reference_renderer.h"

namespace reference {
namespace {

RectMm rect_from(const nlohmann::json& a) {
  RectMm r{a.at(0).get<double>(), a.at(1).get<double>(), a.at(2).get<double>(), a.at(3).get<double>()};
  if (r.x1_mm < r.x0_mm) std::swap(r.x0_mm, r.x1_mm);
  if (r.y1_mm < r.y0_mm) std::swap(r.y0_mm, r.y1_mm);
  return r;
}

Vec2 vec2_from(const nlohmann::json& a) { return {a.at(0).get<double>(), a.at(1).get<double>()}; }

// Area of the unit-free disc x^2 + y^2 <= r^2 between y = -r and y = y_mm.
double disc_area_below(double radius_mm, double y_mm) {
  const double y = std::clamp(y_mm, -radius_mm, radius_mm);
  const double r2 = radius_mm * radius_mm;
  return y * std::sqrt(std::max(0.0, r2 - y * y)) + r2 * std::asin(y / radius_mm) + 0.5 * M_PI * r2;
}

void append_shape(const nlohmann::json& shape, int strips_per_disc, double max_polygon_strip_mm,
                  std::vector<RectMm>& out) {
  const std::string kind = shape.at("kind").get<std::string>();
  if (kind == "rect") {
    out.push_back(rect_from(shape.at("mm")));
  } else if (kind == "disc") {
    const auto strips = disc_strips(vec2_from(shape.at("center_mm")), shape.at("radius_mm").get<double>(),
                                    strips_per_disc);
    out.insert(out.end(), strips.begin(), strips.end());
  } else if (kind == "polygon") {
    std::vector<Vec2> vertices_mm;
    for (const auto& p : shape.at("mm")) vertices_mm.push_back(vec2_from(p));
    const auto strips = polygon_strips(vertices_mm, max_polygon_strip_mm);
    out.insert(out.end(), strips.begin(), strips.end());
  } else {
    throw std::runtime_error("layout: artwork kind '" + kind + "' is not rect, disc or polygon");
  }
}

}  // namespace

Vec2 LayoutElement::center_mm() const {
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (const RectMm& b : bars_mm) {
    x0 = std::min(x0, b.x0_mm);
    y0 = std::min(y0, b.y0_mm);
    x1 = std::max(x1, b.x1_mm);
    y1 = std::max(y1, b.y1_mm);
  }
  return {0.5 * (x0 + x1), 0.5 * (y0 + y1)};
}

std::vector<RectMm> disc_strips(Vec2 center_mm, double radius_mm, int strips) {
  std::vector<RectMm> out;
  const double height_mm = 2 * radius_mm / strips;
  for (int i = 0; i < strips; ++i) {
    const double ya = -radius_mm + i * height_mm;  // relative to the centre
    const double yb = ya + height_mm;
    const double area_mm2 = disc_area_below(radius_mm, yb) - disc_area_below(radius_mm, ya);
    const double half_width_mm = 0.5 * area_mm2 / height_mm;
    out.push_back({center_mm[0] - half_width_mm, center_mm[1] + ya, center_mm[0] + half_width_mm,
                   center_mm[1] + yb});
  }
  return out;
}

std::vector<RectMm> polygon_strips(const std::vector<Vec2>& vertices_mm, double max_strip_mm) {
  std::vector<RectMm> out;
  if (vertices_mm.size() < 3) return out;
  double y_min = 1e300, y_max = -1e300;
  for (const Vec2& v : vertices_mm) {
    y_min = std::min(y_min, v[1]);
    y_max = std::max(y_max, v[1]);
  }
  const int strips = std::max(1, static_cast<int>(std::ceil((y_max - y_min) / max_strip_mm)));
  const double height_mm = (y_max - y_min) / strips;
  std::vector<double> crossings_mm;
  for (int i = 0; i < strips; ++i) {
    const double ya = y_min + i * height_mm, y_mid = ya + 0.5 * height_mm;
    crossings_mm.clear();
    for (size_t k = 0; k < vertices_mm.size(); ++k) {
      const Vec2 a = vertices_mm[k], b = vertices_mm[(k + 1) % vertices_mm.size()];
      if ((a[1] <= y_mid) == (b[1] <= y_mid)) continue;  // edge does not cross the mid line
      crossings_mm.push_back(a[0] + (y_mid - a[1]) / (b[1] - a[1]) * (b[0] - a[0]));
    }
    std::sort(crossings_mm.begin(), crossings_mm.end());
    for (size_t k = 0; k + 1 < crossings_mm.size(); k += 2)
      if (crossings_mm[k + 1] > crossings_mm[k])
        out.push_back({crossings_mm[k], ya, crossings_mm[k + 1], ya + height_mm});
  }
  return out;
}

Layout parse_layout(const nlohmann::json& j, int strips_per_disc, double max_polygon_strip_mm) {
  if (j.value("schema", "") != "tactres.target/1")
    throw std::runtime_error("layout: schema is not tactres.target/1");
  Layout L;
  L.width_mm = j.at("size_mm").at(0).get<double>();
  L.height_mm = j.at("size_mm").at(1).get<double>();
  L.relief_height_mm = j.value("relief_height_mm", 0.1);
  for (const auto& e : j.at("elements")) {
    LayoutElement el;
    el.group = e.at("group").get<int>();
    el.element = e.at("element").get<int>();
    el.lp_per_mm = e.at("lp_per_mm").get<double>();
    el.bar_width_mm = e.at("bar_width_mm").get<double>();
    el.horizontal_bars = e.at("orientation").get<std::string>() == "horizontal_bars";
    for (const auto& b : e.at("bars_mm")) el.bars_mm.push_back(rect_from(b));
    L.elements.push_back(el);
  }
  for (const auto& shape : j.at("artwork")) {
    append_shape(shape, strips_per_disc, max_polygon_strip_mm, L.ink_rects_mm);
    ++L.artwork_shapes;
  }
  return L;
}

Layout read_layout(const std::string& path, int strips_per_disc, double max_polygon_strip_mm) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("layout: cannot open " + path);
  return parse_layout(nlohmann::json::parse(in), strips_per_disc, max_polygon_strip_mm);
}

}  // namespace reference
