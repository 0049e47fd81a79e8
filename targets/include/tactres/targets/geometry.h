#pragma once
// Plane geometry in the target frame: millimetres, origin at the top-left
// corner of the printed face, x right, y down (see docs/CONVENTIONS.md).

#include <algorithm>
#include <cmath>

namespace tactres {

struct Vec2 {
  double x = 0.0;
  double y = 0.0;
};

// A point or direction in 3-D (camera frame or relief mesh), in mm.
struct Vec3 {
  double x = 0.0, y = 0.0, z = 0.0;
};

inline Vec2 operator+(Vec2 a, Vec2 b) { return {a.x + b.x, a.y + b.y}; }
inline Vec2 operator-(Vec2 a, Vec2 b) { return {a.x - b.x, a.y - b.y}; }
inline Vec2 operator*(double s, Vec2 a) { return {s * a.x, s * a.y}; }
inline double dot(Vec2 a, Vec2 b) { return a.x * b.x + a.y * b.y; }
inline double cross(Vec2 a, Vec2 b) { return a.x * b.y - a.y * b.x; }
inline double norm(Vec2 a) { return std::hypot(a.x, a.y); }

// Axis-aligned rectangle [x0, x1] x [y0, y1], with x0 <= x1 and y0 <= y1.
struct RectMm {
  double x0 = 0.0, y0 = 0.0, x1 = 0.0, y1 = 0.0;

  double width_mm() const { return x1 - x0; }
  double height_mm() const { return y1 - y0; }
  double area_mm2() const { return width_mm() * height_mm(); }
  Vec2 center_mm() const { return {0.5 * (x0 + x1), 0.5 * (y0 + y1)}; }
  RectMm inflated(double d_mm) const { return {x0 - d_mm, y0 - d_mm, x1 + d_mm, y1 + d_mm}; }
  RectMm translated(Vec2 d) const { return {x0 + d.x, y0 + d.y, x1 + d.x, y1 + d.y}; }
  bool contains(const RectMm& o) const {
    return o.x0 >= x0 && o.y0 >= y0 && o.x1 <= x1 && o.y1 <= y1;
  }
  // Area of the intersection; 0 for rectangles that only touch.
  double overlap_area_mm2(const RectMm& o) const {
    const double w = std::min(x1, o.x1) - std::max(x0, o.x0);
    const double h = std::min(y1, o.y1) - std::max(y0, o.y0);
    return (w > 0 && h > 0) ? w * h : 0.0;
  }
};

inline RectMm bounding_union(const RectMm& a, const RectMm& b) {
  return {std::min(a.x0, b.x0), std::min(a.y0, b.y0), std::max(a.x1, b.x1), std::max(a.y1, b.y1)};
}

}  // namespace tactres
