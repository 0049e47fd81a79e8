#include "tactres/targets/svg.h"

#include <fmt/format.h>

#include "tactres/util/atomic_file.h"

namespace tactres {
namespace {

const char* role_name(ArtworkShape::Role r) {
  switch (r) {
    case ArtworkShape::Role::bar: return "bar";
    case ArtworkShape::Role::patch: return "patch";
    case ArtworkShape::Role::fiducial: return "fiducial";
    case ArtworkShape::Role::label: return "label";
  }
  return "shape";
}

}  // namespace

std::string target_svg(const TargetLayout& L) {
  const bool dark_ink = L.polarity == Polarity::dark_bars_on_light;
  const char* ink = dark_ink ? "#000000" : "#ffffff";
  const char* ground = dark_ink ? "#ffffff" : "#000000";
  // "{}" prints the shortest representation that reads back to the same
  // double, so the SVG carries the layout's geometry without rounding.
  std::string s = fmt::format(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"{0}mm\" height=\"{1}mm\" "
      "viewBox=\"0 0 {0} {1}\">\n"
      "<title>tactres USAF-1951-style target, groups {2}..{3}, {4}</title>\n"
      "<rect class=\"ground\" x=\"0\" y=\"0\" width=\"{0}\" height=\"{1}\" fill=\"{5}\"/>\n"
      "<g fill=\"{6}\" stroke=\"none\">\n",
      L.width_mm, L.height_mm, L.first_group, L.last_group, to_string(L.polarity), ground, ink);
  for (const ArtworkShape& a : L.artwork) {
    switch (a.kind) {
      case ArtworkShape::Kind::rect:
        s += fmt::format("<rect class=\"{}\" x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\"/>\n",
                         role_name(a.role), a.rect_mm.x0, a.rect_mm.y0, a.rect_mm.width_mm(),
                         a.rect_mm.height_mm());
        break;
      case ArtworkShape::Kind::disc:
        s += fmt::format("<circle class=\"{}\" cx=\"{}\" cy=\"{}\" r=\"{}\"/>\n", role_name(a.role),
                         a.center_mm.x, a.center_mm.y, a.radius_mm);
        break;
      case ArtworkShape::Kind::polygon: {
        std::string pts;
        for (const Vec2& p : a.polygon_mm) pts += fmt::format("{}{},{}", pts.empty() ? "" : " ", p.x, p.y);
        s += fmt::format("<polygon class=\"{}\" points=\"{}\"/>\n", role_name(a.role), pts);
        break;
      }
    }
  }
  s += "</g>\n</svg>\n";
  return s;
}

void write_target_svg(const std::filesystem::path& path, const TargetLayout& layout) {
  write_file_atomically(path, target_svg(layout));
}

}  // namespace tactres
