// The outlines of the relief's raised regions: see stl_outlines.h.
#include "stl_outlines.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <unordered_map>

#include <fmt/format.h>

namespace tactres::stl_detail {

namespace {

bool is_convex(const std::vector<Vec2>& poly) {
  bool pos = false, neg = false;
  for (size_t i = 0; i < poly.size(); ++i) {
    const double o = orient(poly[i], poly[(i + 1) % poly.size()], poly[(i + 2) % poly.size()]);
    pos = pos || o > 0;
    neg = neg || o < 0;
  }
  return !(pos && neg);
}

// Even-odd test; nullopt when q is on the loop's boundary.
std::optional<bool> inside_loop(Vec2 q, const std::vector<int>& loop, const std::vector<Vec2>& pts) {
  bool in = false;
  for (size_t k = 0; k < loop.size(); ++k) {
    const Vec2 a = pts[size_t(loop[k])], b = pts[size_t(loop[(k + 1) % loop.size()])];
    const Vec2 d = b - a;
    const double t = dot(q - a, d) / dot(d, d);
    if (t >= 0 && t <= 1 && norm(q - (a + t * d)) < kOnEdgeMm) return std::nullopt;
    if ((a.y > q.y) != (b.y > q.y) && q.x < a.x + (q.y - a.y) * d.x / d.y) in = !in;
  }
  return in;
}

}  // namespace

// ---------------------------------------------------------------------------
// Input checks: the mesh is only closed if shapes neither overlap nor reach
// the plate's edge.

void check_shapes(const TargetLayout& L, const ArtworkIndex& index,
                  const std::vector<std::vector<Vec2>>& footprints) {
  const RectMm field{0, 0, L.width_mm, L.height_mm};
  std::vector<int> near;
  for (size_t i = 0; i < L.artwork.size(); ++i) {
    const RectMm b = L.artwork[i].bounds_mm();
    if (!(b.x0 > 0 && b.y0 > 0 && b.x1 < field.x1 && b.y1 < field.y1))
      throw std::invalid_argument(fmt::format(
          "artwork shape {} ({:.4g}, {:.4g})..({:.4g}, {:.4g}) mm does not lie strictly inside "
          "the {:g} x {:g} mm plate",
          i, b.x0, b.y0, b.x1, b.y1, L.width_mm, L.height_mm));
    if (footprints[i].size() < 3 || std::abs(signed_area_mm2(footprints[i])) <= 0)
      throw std::invalid_argument(fmt::format("artwork shape {} has no area", i));
    index.query(b, near);
    for (int j : near) {
      if (size_t(j) <= i) continue;
      const ArtworkShape &a = L.artwork[i], &c = L.artwork[size_t(j)];
      double overlap = 0;
      if (is_convex(footprints[size_t(j)]))
        overlap = intersection_area_mm2(a, footprints[size_t(j)]);
      else if (is_convex(footprints[i]))
        overlap = intersection_area_mm2(c, footprints[i]);
      if (overlap > 1e-9 * std::min(a.area_mm2(), c.area_mm2()))
        throw std::invalid_argument(fmt::format(
            "artwork shapes {} and {} overlap by {:.3g} mm^2: a relief needs disjoint shapes", i, j,
            overlap));
    }
  }
}

// ---------------------------------------------------------------------------
// Union outlines. Every shape outline is split wherever another shape's
// vertex lies on it; edges shared by two touching shapes then occur once in
// each direction and cancel. What remains bounds the raised regions, with the
// region on the left.

std::vector<std::pair<int, int>> union_boundary(const std::vector<std::vector<int>>& outlines,
                                                const std::vector<std::vector<int>>& neighbours,
                                                const PointPool& pool, double plate_height_mm) {
  std::unordered_map<std::uint64_t, int> count;
  std::vector<std::pair<int, int>> order;  // first-seen order keeps the output deterministic
  auto add = [&](int a, int b) {
    auto rev = count.find(edge_key(b, a));
    if (rev != count.end() && rev->second > 0) {
      --rev->second;
      return;
    }
    if (count[edge_key(a, b)]++ == 0) order.emplace_back(a, b);
  };

  std::vector<std::pair<double, int>> splits;
  for (size_t s = 0; s < outlines.size(); ++s) {
    const auto& ring = outlines[s];
    for (size_t k = 0; k < ring.size(); ++k) {
      const int u = ring[k], v = ring[(k + 1) % ring.size()];
      const Vec2 pu = pool.pts[size_t(u)], d = pool.pts[size_t(v)] - pu;
      const double len2 = dot(d, d), len = std::sqrt(len2);
      splits.clear();
      for (int n : neighbours[s])
        for (int w : outlines[size_t(n)]) {
          if (w == u || w == v) continue;
          const Vec2 pw = pool.pts[size_t(w)] - pu;
          const double t = dot(pw, d) / len2;
          if (t > 0 && t < 1 && std::abs(cross(d, pw)) / len < kOnEdgeMm) splits.emplace_back(t, w);
        }
      std::sort(splits.begin(), splits.end());
      int from = u;
      for (const auto& [t, w] : splits) {
        if (w == from) continue;
        add(from, w);
        from = w;
      }
      add(from, v);
    }
  }
  std::vector<std::pair<int, int>> edges;
  for (const auto& [a, b] : order) {
    const int c = count[edge_key(a, b)];
    if (c > 1)
      throw std::invalid_argument(fmt::format(
          "artwork shapes overlap along the edge ({:.6g}, {:.6g})-({:.6g}, {:.6g}) mm",
          pool.pts[size_t(a)].x, plate_height_mm - pool.pts[size_t(a)].y, pool.pts[size_t(b)].x,
          plate_height_mm - pool.pts[size_t(b)].y));
    if (c == 1) edges.emplace_back(a, b);
  }
  return edges;
}

// Chains the boundary edges into closed loops. Shapes that meet at a single
// point would make four walls share one vertical edge there, which no
// 2-manifold allows, so such a layout is refused.
std::vector<std::vector<int>> trace_loops(const std::vector<std::pair<int, int>>& edges,
                                          const std::vector<Vec2>& pts, double plate_height_mm) {
  std::unordered_map<int, int> next_edge;
  for (int e = 0; e < int(edges.size()); ++e) {
    const auto [a, b] = edges[size_t(e)];
    if (!next_edge.emplace(a, e).second)
      throw std::invalid_argument(fmt::format(
          "artwork shapes meet at a single point near ({:.6g}, {:.6g}) mm: a relief cannot be a "
          "closed 2-manifold there; separate the shapes or let them share an edge",
          pts[size_t(a)].x, plate_height_mm - pts[size_t(a)].y));
  }
  std::vector<char> used(edges.size(), 0);
  std::vector<std::vector<int>> loops;
  for (int e0 = 0; e0 < int(edges.size()); ++e0) {
    std::vector<int> loop;
    for (int e = e0; !used[size_t(e)];) {
      used[size_t(e)] = 1;
      loop.push_back(edges[size_t(e)].first);
      const auto next = next_edge.find(edges[size_t(e)].second);
      if (next == next_edge.end()) throw std::logic_error("relief mesh: an outline does not close");
      e = next->second;
    }
    if (!loop.empty()) loops.push_back(std::move(loop));
  }
  return loops;
}

// Drops points where an outline runs straight on (merged touching shapes
// leave them), so fewer, better-shaped triangles result.
void drop_straight_points(std::vector<std::vector<int>>& loops, const std::vector<Vec2>& pts) {
  for (auto& loop : loops) {
    const size_t n = loop.size();
    std::vector<int> kept;
    for (size_t k = 0; k < n; ++k) {
      const Vec2 a = pts[size_t(loop[(k + n - 1) % n])], v = pts[size_t(loop[k])],
                 b = pts[size_t(loop[(k + 1) % n])];
      const Vec2 d1 = v - a, d2 = b - v;
      if (!(dot(d1, d2) > 0 && std::abs(cross(d1, d2)) <= 1e-12 * norm(d1) * norm(d2)))
        kept.push_back(loop[k]);
    }
    if (kept.size() < 3) throw std::logic_error("relief mesh: a degenerate outline");
    loop = std::move(kept);
  }
}

// Nests loops that have their material on the left into faces: each
// counter-clockwise loop bounds a face, each clockwise loop is a hole of the
// smallest counter-clockwise loop around it.
std::vector<Face> nest_faces(const std::vector<std::vector<int>>& loops, const std::vector<Vec2>& pts) {
  const size_t n = loops.size();
  std::vector<double> area(n);
  std::vector<RectMm> box(n);
  std::vector<int> face_of(n, -1);
  std::vector<Face> faces;
  for (size_t i = 0; i < n; ++i) {
    std::vector<Vec2> poly;
    for (int v : loops[i]) poly.push_back(pts[size_t(v)]);
    area[i] = signed_area_mm2(poly);
    box[i] = {poly[0].x, poly[0].y, poly[0].x, poly[0].y};
    for (const Vec2& q : poly) box[i] = bounding_union(box[i], {q.x, q.y, q.x, q.y});
    if (area[i] > 0) {
      face_of[i] = int(faces.size());
      faces.push_back({loops[i], {}});
    }
  }
  for (size_t i = 0; i < n; ++i) {
    if (area[i] > 0) continue;
    int parent = -1;
    for (size_t j = 0; j < n; ++j) {
      if (area[j] <= 0 || area[j] <= -area[i] || !box[j].contains(box[i])) continue;
      if (parent >= 0 && area[size_t(parent)] <= area[j]) continue;
      for (int v : loops[i])
        if (auto in = inside_loop(pts[size_t(v)], loops[j], pts)) {
          if (*in) parent = int(j);
          break;
        }
    }
    if (parent < 0) throw std::logic_error("relief mesh: a hole outside every outline");
    faces[size_t(face_of[size_t(parent)])].holes.push_back(loops[i]);
  }
  return faces;
}

}  // namespace tactres::stl_detail
