// The layout's fiducial pattern: its five discs, which three are collinear
// (the identification's seed), and how large the discs are against the
// artwork as a whole (the shaded mode's closing, detect_mode).

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "fiducials_internal.h"

namespace tactres::locate_detail {

namespace {

// (det C)^(1/4), in mm, of the artwork's outlines (every edge of every
// shape, weighted by its length); 0 if there are none.
double outline_spread_mm(const TargetLayout& layout) {
  double L = 0;
  Vec2 S{};
  Sym2 Q{};
  auto segment = [&](Vec2 a, Vec2 b) {
    // Integrals of p and p p^T along the segment a -> b.
    const Vec2 d = b - a;
    const double l = norm(d);
    if (!(l > 0)) return;
    L += l;
    S = S + (0.5 * l) * (a + b);
    Q.xx += l * (a.x * a.x + a.x * d.x + d.x * d.x / 3);
    Q.xy += l * (a.x * a.y + 0.5 * (a.x * d.y + d.x * a.y) + d.x * d.y / 3);
    Q.yy += l * (a.y * a.y + a.y * d.y + d.y * d.y / 3);
  };
  auto outline = [&](const std::vector<Vec2>& p) {
    for (size_t i = 0; i < p.size(); ++i) segment(p[i], p[(i + 1) % p.size()]);
  };
  for (const ArtworkShape& a : layout.artwork) {
    switch (a.kind) {
      case ArtworkShape::Kind::rect: {
        const RectMm& r = a.rect_mm;
        outline({{r.x0, r.y0}, {r.x1, r.y0}, {r.x1, r.y1}, {r.x0, r.y1}});
        break;
      }
      case ArtworkShape::Kind::disc: {
        std::vector<Vec2> p;
        for (int k = 0; k < 32; ++k)
          p.push_back(a.center_mm + a.radius_mm * Vec2{std::cos(2 * kPi * k / 32), std::sin(2 * kPi * k / 32)});
        outline(p);
        break;
      }
      case ArtworkShape::Kind::polygon:
        outline(a.polygon_mm);
        break;
    }
  }
  if (!(L > 0)) return 0;
  const Vec2 m = (1 / L) * S;
  const Sym2 C{Q.xx / L - m.x * m.x, Q.xy / L - m.x * m.y, Q.yy / L - m.y * m.y};
  return C.det() > 0 ? std::sqrt(std::sqrt(C.det())) : 0;
}

}  // namespace

Pattern make_pattern(const TargetLayout& layout) {
  const auto& f = layout.fiducials;
  const std::string hint =
      "the layout's fiducials must be the 5 equal discs TL, T3, TR, BL, BR written by `tactres "
      "generate`";
  // A standard chart's layout (--style mil-std-150a) has none: it is
  // measured in chart mode, which finds the chart itself.
  if (f.empty())
    throw std::invalid_argument(
        "the layout has no fiducials (a standard MIL-STD-150A chart?): measure a standard chart with --chart "
        "usaf1951 instead of --layout; layout mode needs the 5 discs of a target from `tactres generate`");
  if (f.size() != 5)
    throw std::invalid_argument(
        fmt::format("layout has {} fiducials, expected 5: {}", f.size(), hint));
  Pattern P;
  P.r_mm = f[0].radius_mm;
  for (const Fiducial& q : f) {
    if (!(q.radius_mm > 0) || std::abs(q.radius_mm - P.r_mm) > 1e-9 * P.r_mm)
      throw std::invalid_argument("layout fiducials have unequal or non-positive radii: " + hint);
    P.p.push_back(q.center_mm);
    P.id.push_back(q.id);
  }
  int found = 0;
  for (int i = 0; i < 5; ++i)
    for (int k = i + 1; k < 5; ++k)
      for (int j = 0; j < 5; ++j) {
        if (j == i || j == k) continue;
        const Vec2 ik = P.p[k] - P.p[i], ij = P.p[j] - P.p[i];
        const double L2 = dot(ik, ik);
        const double t = dot(ij, ik) / L2;
        if (std::abs(cross(ik, ij)) <= 1e-6 * L2 && t > 0.01 && t < 0.99) {
          ++found;
          if (std::abs(t - 0.5) < 0.05)
            throw std::invalid_argument(
                "layout's collinear fiducial triple has its middle disc at the midpoint, so its "
                "ends cannot be told apart: " +
                hint);
          P.m = j;
          P.a = t < 0.5 ? i : k;
          P.b = t < 0.5 ? k : i;
        }
      }
  if (found != 1)
    throw std::invalid_argument(fmt::format(
        "layout's fiducials contain {} collinear triples, expected exactly 1: {}", found, hint));
  std::vector<int> rest;
  for (int i = 0; i < 5; ++i)
    if (i != P.a && i != P.m && i != P.b) rest.push_back(i);
  const bool first_nearer = norm(P.p[rest[0]] - P.p[P.a]) < norm(P.p[rest[1]] - P.p[P.a]);
  P.c = first_nearer ? rest[0] : rest[1];
  P.d = first_nearer ? rest[1] : rest[0];
  P.field = {Vec2{0, 0}, Vec2{layout.width_mm, 0}, Vec2{layout.width_mm, layout.height_mm},
             Vec2{0, layout.height_mm}};
  P.ab_mm = norm(P.p[P.b] - P.p[P.a]);
  P.patch = layout.reference_patch_mm;
  const double spread = outline_spread_mm(layout);
  P.disc_per_spread = spread > 0 ? P.r_mm / spread : 0;
  return P;
}

}  // namespace tactres::locate_detail
