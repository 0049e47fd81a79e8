#include "tactres/targets/stl.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include <fmt/format.h>

#include "tactres/util/atomic_file.h"
#include "tactres/targets/coverage.h"

namespace tactres {

void StlOptions::validate() const {
  if (disc_segments < 8 || disc_segments > 4096)
    throw std::invalid_argument(
        fmt::format("disc segments must be in [8, 4096], got {}", disc_segments));
}

double TriangleMesh::volume_mm3() const {
  double six_v = 0.0;
  for (const auto& t : triangles) {
    const Vec3 &a = vertices[size_t(t[0])], &b = vertices[size_t(t[1])], &c = vertices[size_t(t[2])];
    six_v += a.x * (b.y * c.z - b.z * c.y) + a.y * (b.z * c.x - b.x * c.z) + a.z * (b.x * c.y - b.y * c.x);
  }
  return six_v / 6.0;
}

std::vector<Vec2> mesh_footprint_mm(const ArtworkShape& s, const StlOptions& options) {
  switch (s.kind) {
    case ArtworkShape::Kind::rect: {
      const RectMm& r = s.rect_mm;
      return {{r.x0, r.y0}, {r.x1, r.y0}, {r.x1, r.y1}, {r.x0, r.y1}};
    }
    case ArtworkShape::Kind::disc: {
      std::vector<Vec2> p(size_t(options.disc_segments));
      for (int k = 0; k < options.disc_segments; ++k) {
        const double a = 2 * std::numbers::pi * k / options.disc_segments;
        p[size_t(k)] = s.center_mm + s.radius_mm * Vec2{std::cos(a), std::sin(a)};
      }
      return p;
    }
    case ArtworkShape::Kind::polygon: return s.polygon_mm;
  }
  return {};
}

namespace {

// ---------------------------------------------------------------------------
// Planar points. Coordinates are snapped to 2^-30 mm (exact in a double) so
// that shapes meant to touch share vertices exactly; a point's id is its
// identity everywhere below (loops, faces, walls).

constexpr double kSnapPerMm = 1073741824.0;  // 2^30
constexpr double kOnEdgeMm = 4e-9;           // a few snap steps

struct PointPool {
  std::vector<Vec2> pts;
  std::unordered_map<std::uint64_t, std::vector<int>> buckets;  // hash -> ids

  int id(Vec2 p) {
    const long long qx = std::llround(p.x * kSnapPerMm), qy = std::llround(p.y * kSnapPerMm);
    const Vec2 snapped{double(qx) / kSnapPerMm, double(qy) / kSnapPerMm};
    const std::uint64_t h = std::uint64_t(qx) * 0x9E3779B97F4A7C15ull ^ std::uint64_t(qy);
    auto& ids = buckets[h];
    for (int i : ids)
      if (pts[size_t(i)].x == snapped.x && pts[size_t(i)].y == snapped.y) return i;
    pts.push_back(snapped);
    ids.push_back(int(pts.size() - 1));
    return int(pts.size() - 1);
  }
};

double orient(Vec2 a, Vec2 b, Vec2 c) { return cross(b - a, c - a); }

std::uint64_t edge_key(int a, int b) { return (std::uint64_t(std::uint32_t(a)) << 32) | std::uint32_t(b); }

bool is_convex(const std::vector<Vec2>& poly) {
  bool pos = false, neg = false;
  for (size_t i = 0; i < poly.size(); ++i) {
    const double o = orient(poly[i], poly[(i + 1) % poly.size()], poly[(i + 2) % poly.size()]);
    pos = pos || o > 0;
    neg = neg || o < 0;
  }
  return !(pos && neg);
}

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

// ---------------------------------------------------------------------------
// Ear clipping of a polygon with holes (outer counter-clockwise, holes
// clockwise). Holes are bridged to the outer ring in order of their leftmost
// vertex, each to the nearest visible vertex on its left. No vertices are
// added, so the faces meet the walls edge for edge. Ears are tested against
// every live vertex through a uniform grid.

class EarClipper {
 public:
  explicit EarClipper(const std::vector<Vec2>& pts) : pts_(pts) {}

  void triangulate(const std::vector<int>& outer, const std::vector<std::vector<int>>& holes,
                   std::vector<std::array<int, 3>>& tris) {
    nodes_.clear();
    const int start = make_ring(outer);
    std::vector<int> hole_starts;
    for (const auto& h : holes) {
      const int r = make_ring(h);
      int left = r;  // leftmost, lowest on ties
      for (int n = nodes_[size_t(r)].next; n != r; n = nodes_[size_t(n)].next)
        if (p(n).x < p(left).x || (p(n).x == p(left).x && p(n).y < p(left).y)) left = n;
      hole_starts.push_back(left);
    }
    std::sort(hole_starts.begin(), hole_starts.end(), [&](int a, int b) {
      return p(a).x < p(b).x || (p(a).x == p(b).x && p(a).y < p(b).y);
    });
    for (int m : hole_starts) bridge(m, start);
    clip_ears(start, tris);
  }

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
  int gx_ = 1, gy_ = 1;

  Vec2 p(int n) const { return pts_[size_t(nodes_[size_t(n)].id)]; }
  Node& at(int n) { return nodes_[size_t(n)]; }

  int make_ring(const std::vector<int>& ids) {
    const int first = int(nodes_.size()), n = int(ids.size());
    for (int k = 0; k < n; ++k)
      nodes_.push_back({ids[size_t(k)], first + (k + n - 1) % n, first + (k + 1) % n});
    return first;
  }

  // Is `dir` strictly inside the polygon's interior angle at node n?
  bool in_sector(int n, Vec2 dir) const {
    const Vec2 o = p(n), a = p(nodes_[size_t(n)].prev), b = p(nodes_[size_t(n)].next);
    const Vec2 out = b - o, back = a - o;
    if (cross(o - a, b - o) > 0) return cross(out, dir) > 0 && cross(dir, back) > 0;
    return !(cross(back, dir) >= 0 && cross(dir, out) >= 0);
  }

  static bool on_segment(Vec2 a, Vec2 b, Vec2 q) {  // q collinear with a-b
    return std::min(a.x, b.x) <= q.x && q.x <= std::max(a.x, b.x) && std::min(a.y, b.y) <= q.y &&
           q.y <= std::max(a.y, b.y);
  }
  // Closed segments a-b and c-d share a point.
  static bool segments_meet(Vec2 a, Vec2 b, Vec2 c, Vec2 d) {
    const double d1 = orient(c, d, a), d2 = orient(c, d, b), d3 = orient(a, b, c), d4 = orient(a, b, d);
    if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0)))
      return true;
    return (d1 == 0 && on_segment(c, d, a)) || (d2 == 0 && on_segment(c, d, b)) ||
           (d3 == 0 && on_segment(a, b, c)) || (d4 == 0 && on_segment(a, b, d));
  }

  void bridge(int m, int start) {
    const Vec2 pm = p(m);
    std::vector<int> ring;
    for (int n = start;;) {
      ring.push_back(n);
      if ((n = at(n).next) == start) break;
    }
    std::vector<std::pair<double, int>> candidates;
    for (int n : ring)
      if (p(n).x < pm.x) candidates.emplace_back(dot(p(n) - pm, p(n) - pm), n);
    std::sort(candidates.begin(), candidates.end());
    int tested_id = -1;
    for (const auto& [d2, v] : candidates) {
      const int vid = at(v).id;
      if (vid == tested_id) continue;
      tested_id = vid;
      const Vec2 pv = p(v);
      bool blocked = false;
      for (size_t k = 0; k < ring.size() && !blocked; ++k) {
        const int a = ring[k], b = at(a).next;
        if (at(a).id == vid || at(b).id == vid || at(a).id == at(m).id || at(b).id == at(m).id)
          continue;
        blocked = segments_meet(pm, pv, p(a), p(b));
      }
      if (blocked) continue;
      for (int n : ring)
        if (at(n).id == vid && in_sector(n, pm - pv)) {
          splice(n, m);
          return;
        }
    }
    throw std::logic_error("relief mesh: no bridge from a hole to its outline");
  }

  // Links ring node a to hole node b through a two-way slit:
  // a -> b -> ... -> b' -> a' -> (a's old next).
  void splice(int a, int b) {
    const Node a_copy = at(a), b_copy = at(b);
    const int a2 = int(nodes_.size()), b2 = a2 + 1;
    nodes_.push_back(a_copy);
    nodes_.push_back(b_copy);
    const int an = at(a).next, bp = at(b).prev;
    at(a).next = b;
    at(b).prev = a;
    at(bp).next = b2;
    at(b2).prev = bp;
    at(b2).next = a2;
    at(a2).prev = b2;
    at(a2).next = an;
    at(an).prev = a2;
  }

  void build_grid(int start, int count) {
    grid_box_ = {p(start).x, p(start).y, p(start).x, p(start).y};
    for (int n = at(start).next; n != start; n = at(n).next)
      grid_box_ = bounding_union(grid_box_, {p(n).x, p(n).y, p(n).x, p(n).y});
    const double span = std::max({grid_box_.width_mm(), grid_box_.height_mm(), 1e-9});
    cell_ = std::max(std::sqrt(std::max(grid_box_.area_mm2(), span * span * 1e-4) / count), span / 512);
    gx_ = int(grid_box_.width_mm() / cell_) + 1;
    gy_ = int(grid_box_.height_mm() / cell_) + 1;
    grid_.assign(size_t(gx_) * size_t(gy_), {});
    int n = start;
    do {
      grid_[cell_of(p(n))].push_back(n);
      n = at(n).next;
    } while (n != start);
  }
  int gi(double x) const { return std::clamp(int((x - grid_box_.x0) / cell_), 0, gx_ - 1); }
  int gj(double y) const { return std::clamp(int((y - grid_box_.y0) / cell_), 0, gy_ - 1); }
  size_t cell_of(Vec2 q) const { return size_t(gj(q.y)) * size_t(gx_) + size_t(gi(q.x)); }

  bool is_ear(int b) const {
    const int a = nodes_[size_t(b)].prev, c = nodes_[size_t(b)].next;
    const Vec2 pa = p(a), pb = p(b), pc = p(c);
    if (orient(pa, pb, pc) <= 0) return false;
    if (!in_sector(a, pc - pa) || !in_sector(c, pa - pc)) return false;
    const int ia = nodes_[size_t(a)].id, ib = nodes_[size_t(b)].id, ic = nodes_[size_t(c)].id;
    const int i0 = gi(std::min({pa.x, pb.x, pc.x})), i1 = gi(std::max({pa.x, pb.x, pc.x}));
    const int j0 = gj(std::min({pa.y, pb.y, pc.y})), j1 = gj(std::max({pa.y, pb.y, pc.y}));
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i)
        for (int n : grid_[size_t(j) * size_t(gx_) + size_t(i)]) {
          const Node& q = nodes_[size_t(n)];
          if (q.removed || q.id == ia || q.id == ib || q.id == ic) continue;
          const Vec2 pq = p(n);
          if (orient(pa, pb, pq) >= 0 && orient(pb, pc, pq) >= 0 && orient(pc, pa, pq) >= 0)
            return false;  // a vertex in the closed triangle: not an ear
        }
    return true;
  }

  void clip_ears(int start, std::vector<std::array<int, 3>>& tris) {
    int count = 1;
    for (int n = at(start).next; n != start; n = at(n).next) ++count;
    build_grid(start, count);
    int cur = start, misses = 0;
    while (count > 3) {
      if (is_ear(cur)) {
        const int a = at(cur).prev, c = at(cur).next;
        tris.push_back({at(a).id, at(cur).id, at(c).id});
        at(cur).removed = true;
        at(a).next = c;
        at(c).prev = a;
        --count;
        cur = c;
        misses = 0;
      } else {
        cur = at(cur).next;
        if (++misses > count) throw std::logic_error("relief mesh: ear clipping found no ear");
      }
    }
    const int a = at(cur).prev, c = at(cur).next;
    if (orient(p(a), p(cur), p(c)) <= 0)
      throw std::logic_error("relief mesh: a degenerate last triangle");
    tris.push_back({at(a).id, at(cur).id, at(c).id});
  }
};

struct Face {
  std::vector<int> outer;               // counter-clockwise
  std::vector<std::vector<int>> holes;  // clockwise
};

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

}  // namespace

TriangleMesh relief_mesh(const TargetLayout& L, const StlOptions& options) {
  options.validate();
  if (!(L.width_mm > 0 && L.height_mm > 0 && L.base_thickness_mm > 0 && L.relief_height_mm > 0))
    throw std::invalid_argument("relief mesh: plate size, base thickness and relief height must be > 0");
  const ArtworkIndex index(L.artwork);
  std::vector<std::vector<Vec2>> footprints;
  for (const ArtworkShape& s : L.artwork) footprints.push_back(mesh_footprint_mm(s, options));
  check_shapes(L, index, footprints);

  // Outlines in the mesh frame (y flipped), counter-clockwise.
  PointPool pool;
  std::vector<std::vector<int>> outlines;
  for (const auto& f : footprints) {
    std::vector<int> ring;
    for (const Vec2& q : f) {
      const int id = pool.id({q.x, L.height_mm - q.y});
      if (ring.empty() || ring.back() != id) ring.push_back(id);
    }
    while (ring.size() > 1 && ring.back() == ring.front()) ring.pop_back();
    std::vector<Vec2> poly;
    for (int v : ring) poly.push_back(pool.pts[size_t(v)]);
    if (signed_area_mm2(poly) < 0) std::reverse(ring.begin(), ring.end());
    outlines.push_back(std::move(ring));
  }
  std::vector<std::vector<int>> neighbours(L.artwork.size());
  for (size_t s = 0; s < L.artwork.size(); ++s) {
    index.query(L.artwork[s].bounds_mm().inflated(1e-6), neighbours[s]);
    std::erase(neighbours[s], int(s));
  }

  auto loops = trace_loops(union_boundary(outlines, neighbours, pool, L.height_mm), pool.pts,
                           L.height_mm);
  drop_straight_points(loops, pool.pts);

  // Raised faces: the loops as traced (region on the left). Ground faces:
  // the same loops reversed, inside the plate's outline.
  const double W = L.width_mm, H = L.height_mm;
  std::vector<std::vector<int>> ground_loops;
  for (const auto& l : loops) ground_loops.emplace_back(l.rbegin(), l.rend());
  ground_loops.push_back({pool.id({0, 0}), pool.id({W, 0}), pool.id({W, H}), pool.id({0, H})});
  const std::vector<int>& plate = ground_loops.back();
  const std::vector<Face> raised_faces = nest_faces(loops, pool.pts);
  const std::vector<Face> ground_faces = nest_faces(ground_loops, pool.pts);

  // 3-D vertices: each planar point at the levels it is used on.
  TriangleMesh mesh;
  const double z[3] = {0.0, L.base_thickness_mm, L.base_thickness_mm + L.relief_height_mm};
  std::vector<std::array<int, 3>> vid(pool.pts.size(), {-1, -1, -1});
  auto v3 = [&](int id, int level) {
    int& slot = vid[size_t(id)][size_t(level)];
    if (slot < 0) {
      slot = int(mesh.vertices.size());
      mesh.vertices.push_back({pool.pts[size_t(id)].x, pool.pts[size_t(id)].y, z[level]});
    }
    return slot;
  };
  auto tri = [&](int a, int b, int c) { mesh.triangles.push_back({a, b, c}); };

  EarClipper clipper(pool.pts);
  std::vector<std::array<int, 3>> flat;
  for (int level : {1, 2})
    for (const Face& f : level == 2 ? raised_faces : ground_faces) {
      flat.clear();
      clipper.triangulate(f.outer, f.holes, flat);
      for (const auto& t : flat) tri(v3(t[0], level), v3(t[1], level), v3(t[2], level));
    }
  // Walls face away from the region on their left; the plate's sides alike.
  auto wall = [&](int a, int b, int lo, int hi) {
    tri(v3(a, lo), v3(b, lo), v3(b, hi));
    tri(v3(a, lo), v3(b, hi), v3(a, hi));
  };
  for (const auto& loop : loops)
    for (size_t k = 0; k < loop.size(); ++k) wall(loop[k], loop[(k + 1) % loop.size()], 1, 2);
  for (size_t k = 0; k < 4; ++k) wall(plate[k], plate[(k + 1) % 4], 0, 1);
  tri(v3(plate[0], 0), v3(plate[2], 0), v3(plate[1], 0));  // bottom, facing -z
  tri(v3(plate[0], 0), v3(plate[3], 0), v3(plate[2], 0));

  // Self-check: each directed edge once, and its twin once.
  std::unordered_map<std::uint64_t, int> directed;
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) ++directed[edge_key(t[size_t(k)], t[size_t((k + 1) % 3)])];
  for (const auto& [key, c] : directed) {
    const auto twin = directed.find((key << 32) | (key >> 32));
    if (c != 1 || twin == directed.end() || twin->second != 1)
      throw std::logic_error("relief mesh: the mesh is not a closed 2-manifold");
  }
  return mesh;
}

void write_binary_stl(const std::filesystem::path& path, const TriangleMesh& mesh,
                      std::string_view header) {
  static_assert(std::endian::native == std::endian::little, "binary STL is little-endian");
  std::string bytes(80, ' ');
  // A header starting with "solid" makes some readers take the file for ASCII.
  bytes.replace(0, std::min<size_t>(80, header.size()), header.substr(0, 80));
  if (bytes.starts_with("solid")) bytes[0] = 'S';
  auto put = [&](const void* p, size_t n) { bytes.append(static_cast<const char*>(p), n); };
  const std::uint32_t count = std::uint32_t(mesh.triangles.size());
  put(&count, 4);
  bytes.reserve(bytes.size() + size_t(count) * 50);
  for (const auto& t : mesh.triangles) {
    const Vec3 &a = mesh.vertices[size_t(t[0])], &b = mesh.vertices[size_t(t[1])],
               &c = mesh.vertices[size_t(t[2])];
    const Vec3 u{b.x - a.x, b.y - a.y, b.z - a.z}, v{c.x - a.x, c.y - a.y, c.z - a.z};
    Vec3 n{u.y * v.z - u.z * v.y, u.z * v.x - u.x * v.z, u.x * v.y - u.y * v.x};
    const double len = std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    if (len > 0) n = {n.x / len, n.y / len, n.z / len};
    const float f[12] = {float(n.x), float(n.y), float(n.z), float(a.x), float(a.y), float(a.z),
                         float(b.x), float(b.y), float(b.z), float(c.x), float(c.y), float(c.z)};
    put(f, sizeof f);
    const std::uint16_t attr = 0;
    put(&attr, 2);
  }
  write_file_atomically(path, bytes);
}

void write_relief_stl(const std::filesystem::path& path, const TargetLayout& layout,
                      const StlOptions& options) {
  write_binary_stl(path, relief_mesh(layout, options));
}

}  // namespace tactres
