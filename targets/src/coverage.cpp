#include "tactres/targets/coverage.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace tactres {
namespace {

// floor(v) clamped to [0, n - 1], clamped as a double: casting an
// out-of-range or NaN v to int is UB (found by fuzzing: a layout whose
// elements lie ~1e17 cells from its artwork).
int cell_index(double v, int n) {
  if (!(v >= 0)) return 0;
  return v >= n - 1 ? n - 1 : static_cast<int>(std::floor(v));
}

RectMm bounds_of(std::span<const Vec2> pts) {
  RectMm b{pts[0].x, pts[0].y, pts[0].x, pts[0].y};
  for (const Vec2& p : pts) b = bounding_union(b, {p.x, p.y, p.x, p.y});
  return b;
}

bool disjoint(const RectMm& a, const RectMm& b) {
  return a.x1 <= b.x0 || b.x1 <= a.x0 || a.y1 <= b.y0 || b.y1 <= a.y0;
}

// Sutherland-Hodgman step: keeps the part of `in` where side(p) >= 0, for an
// affine side(). Correct for any simple subject against a convex clip window
// (the result may hold zero-width slivers, which add no area).
template <class Side>
void clip_half_plane(const std::vector<Vec2>& in, std::vector<Vec2>& out, Side side) {
  out.clear();
  const size_t n = in.size();
  for (size_t i = 0; i < n; ++i) {
    const Vec2 a = in[i], b = in[(i + 1) % n];
    const double sa = side(a), sb = side(b);
    if (sa >= 0) out.push_back(a);
    if ((sa >= 0) != (sb >= 0)) out.push_back(a + (sa / (sa - sb)) * (b - a));
  }
}

// Area of the subject polygon clipped to a rectangle (subject any winding).
double clipped_to_rect_area(std::span<const Vec2> subject, const RectMm& r) {
  // Scratch reused per thread: the simulator calls this millions of times.
  thread_local std::vector<Vec2> a, b;
  a.assign(subject.begin(), subject.end());
  clip_half_plane(a, b, [&](Vec2 p) { return p.x - r.x0; });
  clip_half_plane(b, a, [&](Vec2 p) { return r.x1 - p.x; });
  clip_half_plane(a, b, [&](Vec2 p) { return p.y - r.y0; });
  clip_half_plane(b, a, [&](Vec2 p) { return r.y1 - p.y; });
  return a.size() < 3 ? 0.0 : std::abs(signed_area_mm2(a));
}

// Area of the subject polygon clipped to a convex window (both any winding).
double clipped_to_convex_area(std::span<const Vec2> subject, std::span<const Vec2> window) {
  thread_local std::vector<Vec2> a, b;
  const double orient = signed_area_mm2(window) >= 0 ? 1.0 : -1.0;
  a.assign(subject.begin(), subject.end());
  const size_t m = window.size();
  for (size_t i = 0; i < m && a.size() >= 3; ++i) {
    const Vec2 e0 = window[i], e = window[(i + 1) % m] - e0;
    clip_half_plane(a, b, [&](Vec2 p) { return orient * cross(e, p - e0); });
    std::swap(a, b);
  }
  return a.size() < 3 ? 0.0 : std::abs(signed_area_mm2(a));
}

// Signed area of disc(0, r) intersected with triangle (0, a, b): positive if
// (0, a, b) is counter-clockwise. The segment a-b is split where it crosses
// the circle; pieces inside contribute triangles, pieces outside sectors.
double disc_triangle_signed_area(Vec2 a, Vec2 b, double r) {
  const Vec2 d = b - a;
  const double A = dot(d, d);
  if (A == 0.0) return 0.0;
  const double B = dot(a, d), C = dot(a, a) - r * r;  // |a + t d|^2 = r^2
  double ts[4] = {0.0, 0.0, 0.0, 0.0};
  int n = 1;
  const double disc = B * B - A * C;
  if (disc > 0) {
    // Stable roots: q carries B's sign so no cancellation.
    const double q = -(B + std::copysign(std::sqrt(disc), B));
    double t1 = q / A, t2 = q != 0 ? C / q : t1;
    if (t1 > t2) std::swap(t1, t2);
    if (t1 > 0 && t1 < 1) ts[n++] = t1;
    if (t2 > 0 && t2 < 1) ts[n++] = t2;
  }
  ts[n++] = 1.0;
  double area = 0.0;
  for (int k = 0; k + 1 < n; ++k) {
    const Vec2 u = a + ts[k] * d, v = a + ts[k + 1] * d;
    const Vec2 mid = a + (0.5 * (ts[k] + ts[k + 1])) * d;
    if (dot(mid, mid) <= r * r)
      area += 0.5 * cross(u, v);
    else
      area += 0.5 * r * r * std::atan2(cross(u, v), dot(u, v));
  }
  return area;
}

}  // namespace

double signed_area_mm2(std::span<const Vec2> polygon) {
  double twice = 0.0;
  const size_t n = polygon.size();
  for (size_t i = 0; i < n; ++i) twice += cross(polygon[i], polygon[(i + 1) % n]);
  return 0.5 * twice;
}

double disc_convex_polygon_area_mm2(Vec2 c, double r, std::span<const Vec2> poly) {
  if (poly.size() < 3 || r <= 0) return 0.0;
  const RectMm disc_bounds{c.x - r, c.y - r, c.x + r, c.y + r};
  if (disjoint(bounds_of(poly), disc_bounds)) return 0.0;
  const double area = signed_area_mm2(poly);
  const double orient = area >= 0 ? 1.0 : -1.0;
  const size_t n = poly.size();

  bool all_inside_disc = true;
  for (const Vec2& p : poly) all_inside_disc = all_inside_disc && norm(p - c) <= r;
  if (all_inside_disc) return std::abs(area);  // the disc is convex

  bool disc_inside_poly = true;
  for (size_t i = 0; i < n && disc_inside_poly; ++i) {
    const Vec2 e = poly[(i + 1) % n] - poly[i];
    const double len = norm(e);
    disc_inside_poly = len > 0 && orient * cross(e, c - poly[i]) / len >= r;
  }
  if (disc_inside_poly) return std::numbers::pi * r * r;

  double sum = 0.0;
  for (size_t i = 0; i < n; ++i)
    sum += disc_triangle_signed_area(poly[i] - c, poly[(i + 1) % n] - c, r);
  return std::max(0.0, orient * sum);
}

double intersection_area_mm2(const ArtworkShape& shape, std::span<const Vec2> poly) {
  if (poly.size() < 3) return 0.0;
  const RectMm pb = bounds_of(poly);
  const RectMm sb = shape.bounds_mm();
  if (disjoint(pb, sb)) return 0.0;
  switch (shape.kind) {
    case ArtworkShape::Kind::rect:
      if (shape.rect_mm.contains(pb)) return std::abs(signed_area_mm2(poly));
      return clipped_to_rect_area(poly, shape.rect_mm);
    case ArtworkShape::Kind::disc:
      return disc_convex_polygon_area_mm2(shape.center_mm, shape.radius_mm, poly);
    case ArtworkShape::Kind::polygon:
      if (shape.polygon_mm.size() < 3) return 0.0;
      return clipped_to_convex_area(shape.polygon_mm, poly);
  }
  return 0.0;
}

double intersection_area_mm2(const ArtworkShape& shape, const RectMm& w) {
  switch (shape.kind) {
    case ArtworkShape::Kind::rect: return shape.rect_mm.overlap_area_mm2(w);
    case ArtworkShape::Kind::disc: {
      if (disjoint(w, shape.bounds_mm())) return 0.0;
      const Vec2 quad[4] = {{w.x0, w.y0}, {w.x1, w.y0}, {w.x1, w.y1}, {w.x0, w.y1}};
      return disc_convex_polygon_area_mm2(shape.center_mm, shape.radius_mm, quad);
    }
    case ArtworkShape::Kind::polygon:
      if (shape.polygon_mm.size() < 3) return 0.0;
      if (disjoint(w, shape.bounds_mm())) return 0.0;
      if (w.contains(shape.bounds_mm())) return shape.area_mm2();
      return clipped_to_rect_area(shape.polygon_mm, w);
  }
  return 0.0;
}

ArtworkIndex::ArtworkIndex(std::span<const ArtworkShape> shapes, double cell_mm) {
  bounds_.reserve(shapes.size());
  for (const ArtworkShape& s : shapes) bounds_.push_back(s.bounds_mm());
  if (bounds_.empty()) {
    cell_begin_.assign(1, 0);
    return;
  }
  extent_ = bounds_[0];
  for (const RectMm& b : bounds_) extent_ = bounding_union(extent_, b);
  const double span = std::max({extent_.width_mm(), extent_.height_mm(), 1e-9});
  if (!(cell_mm > 0)) {
    // About one shape per cell on average, but never a grid finer than
    // 1024 cells per side.
    cell_mm = std::sqrt(std::max(extent_.area_mm2(), span * span * 1e-6) / double(bounds_.size()));
  }
  cell_mm_ = std::max(cell_mm, span / 1024.0);
  // At most 1024 cells per side (cell_mm_ >= span / 1024); 1 when the
  // extent overflows to inf and the ratio is NaN.
  nx_ = std::max(1, cell_index(std::ceil(extent_.width_mm() / cell_mm_), 1026));
  ny_ = std::max(1, cell_index(std::ceil(extent_.height_mm() / cell_mm_), 1026));

  auto cell_range = [&](const RectMm& b, int& i0, int& i1, int& j0, int& j1) {
    i0 = cell_index((b.x0 - extent_.x0) / cell_mm_, nx_);
    i1 = cell_index((b.x1 - extent_.x0) / cell_mm_, nx_);
    j0 = cell_index((b.y0 - extent_.y0) / cell_mm_, ny_);
    j1 = cell_index((b.y1 - extent_.y0) / cell_mm_, ny_);
  };
  // Two passes build the compressed rows without per-cell vectors.
  std::vector<int> count(size_t(nx_) * ny_ + 1, 0);
  int i0, i1, j0, j1;
  for (const RectMm& b : bounds_) {
    cell_range(b, i0, i1, j0, j1);
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) ++count[size_t(j) * nx_ + i + 1];
  }
  for (size_t c = 1; c < count.size(); ++c) count[c] += count[c - 1];
  cell_begin_ = count;
  items_.resize(size_t(count.back()));
  for (int s = 0; s < int(bounds_.size()); ++s) {
    cell_range(bounds_[s], i0, i1, j0, j1);
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) items_[size_t(count[size_t(j) * nx_ + i]++)] = s;
  }
}

void ArtworkIndex::query(const RectMm& w, std::vector<int>& out) const {
  out.clear();
  if (bounds_.empty() || w.x1 < extent_.x0 || w.x0 > extent_.x1 || w.y1 < extent_.y0 ||
      w.y0 > extent_.y1)
    return;
  const int i0 = cell_index((w.x0 - extent_.x0) / cell_mm_, nx_);
  const int i1 = cell_index((w.x1 - extent_.x0) / cell_mm_, nx_);
  const int j0 = cell_index((w.y0 - extent_.y0) / cell_mm_, ny_);
  const int j1 = cell_index((w.y1 - extent_.y0) / cell_mm_, ny_);
  for (int j = j0; j <= j1; ++j)
    for (int i = i0; i <= i1; ++i) {
      const size_t c = size_t(j) * nx_ + i;
      for (int k = cell_begin_[c]; k < cell_begin_[c + 1]; ++k) {
        const RectMm& b = bounds_[size_t(items_[size_t(k)])];
        if (b.x0 <= w.x1 && w.x0 <= b.x1 && b.y0 <= w.y1 && w.y0 <= b.y1)
          out.push_back(items_[size_t(k)]);
      }
    }
  // Each cell lists a shape once and each cell's list is ascending, so only a
  // multi-cell query needs merging.
  if (i0 != i1 || j0 != j1) {
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
  }
}

std::vector<int> ArtworkIndex::query(const RectMm& window) const {
  std::vector<int> out;
  query(window, out);
  return out;
}

}  // namespace tactres
