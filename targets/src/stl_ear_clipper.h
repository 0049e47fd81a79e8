#pragma once
// Ear clipping of a polygon with holes for the relief mesh's flat faces
// (private to targets; used by relief_mesh in stl.cpp).
//
// Outer ring counter-clockwise, holes clockwise, all as ids into one point
// list. Holes are bridged to the outer ring in order of their leftmost
// vertex, each to the nearest visible vertex on its left. No vertices are
// added, so the faces meet the walls edge for edge. Ears are tested against
// every live vertex through a uniform grid.

#include <algorithm>
#include <array>
#include <cstddef>
#include <vector>

#include "tactres/targets/geometry.h"

namespace tactres::stl_detail {

class EarClipper {
 public:
  // `pts` must outlive the clipper; one clipper serves many faces.
  explicit EarClipper(const std::vector<Vec2>& pts) : pts_(pts) {}

  // Appends the triangles (point ids, counter-clockwise) to `tris`. Throws
  // std::logic_error if the polygon is degenerate.
  void triangulate(const std::vector<int>& outer, const std::vector<std::vector<int>>& holes,
                   std::vector<std::array<int, 3>>& tris);

 private:
  struct Node {
    int id;
    int prev, next;
    bool removed = false;
  };
  const std::vector<Vec2>& pts_;
  std::vector<Node> nodes_;
  std::vector<std::vector<int>> grid_;
  RectMm grid_box_;
  double cell_ = 1;
  // Ears flatter than this are clipped only when no other is left: ten
  // float32 steps at the outline's largest coordinate (build_grid).
  double min_ear_height_mm_ = 0;
  int gx_ = 1, gy_ = 1;

  Vec2 p(int n) const { return pts_[size_t(nodes_[size_t(n)].id)]; }
  Node& at(int n) { return nodes_[size_t(n)]; }
  int gi(double x) const { return std::clamp(int((x - grid_box_.x0) / cell_), 0, gx_ - 1); }
  int gj(double y) const { return std::clamp(int((y - grid_box_.y0) / cell_), 0, gy_ - 1); }
  size_t cell_of(Vec2 q) const { return size_t(gj(q.y)) * size_t(gx_) + size_t(gi(q.x)); }

  int make_ring(const std::vector<int>& ids);
  bool in_sector(int n, Vec2 dir) const;
  void bridge(int m, int start);
  void splice(int a, int b);
  void build_grid(int start, int count);
  // `min_height_mm`: b must stand at least this far off the line a-c (a
  // sliver thinner than float32 can hold flips or vanishes in the STL).
  bool is_ear(int b, double min_height_mm) const;
  // Of the ring through `start`, the ear whose tip stands farthest off the
  // line between its neighbours (`start` if none is an ear).
  int tallest_ear(int start) const;
  void clip_ears(int start, std::vector<std::array<int, 3>>& tris);
};

}  // namespace tactres::stl_detail
