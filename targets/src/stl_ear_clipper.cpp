// Ear clipping of a polygon with holes: see stl_ear_clipper.h.
#include "stl_ear_clipper.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

#include "stl_planar.h"

namespace tactres::stl_detail {

namespace {

bool on_segment(Vec2 a, Vec2 b, Vec2 q) {  // q collinear with a-b
  return std::min(a.x, b.x) <= q.x && q.x <= std::max(a.x, b.x) && std::min(a.y, b.y) <= q.y &&
         q.y <= std::max(a.y, b.y);
}

// Closed segments a-b and c-d share a point.
bool segments_meet(Vec2 a, Vec2 b, Vec2 c, Vec2 d) {
  const double d1 = orient(c, d, a), d2 = orient(c, d, b), d3 = orient(a, b, c), d4 = orient(a, b, d);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0)))
    return true;
  return (d1 == 0 && on_segment(c, d, a)) || (d2 == 0 && on_segment(c, d, b)) ||
         (d3 == 0 && on_segment(a, b, c)) || (d4 == 0 && on_segment(a, b, d));
}

}  // namespace

void EarClipper::triangulate(const std::vector<int>& outer, const std::vector<std::vector<int>>& holes,
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

int EarClipper::make_ring(const std::vector<int>& ids) {
  const int first = int(nodes_.size()), n = int(ids.size());
  for (int k = 0; k < n; ++k)
    nodes_.push_back({ids[size_t(k)], first + (k + n - 1) % n, first + (k + 1) % n});
  return first;
}

// Is `dir` strictly inside the polygon's interior angle at node n?
bool EarClipper::in_sector(int n, Vec2 dir) const {
  const Vec2 o = p(n), a = p(nodes_[size_t(n)].prev), b = p(nodes_[size_t(n)].next);
  const Vec2 out = b - o, back = a - o;
  if (cross(o - a, b - o) > 0) return cross(out, dir) > 0 && cross(dir, back) > 0;
  return !(cross(back, dir) >= 0 && cross(dir, out) >= 0);
}

void EarClipper::bridge(int m, int start) {
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
void EarClipper::splice(int a, int b) {
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

void EarClipper::build_grid(int start, int count) {
  grid_box_ = {p(start).x, p(start).y, p(start).x, p(start).y};
  for (int n = at(start).next; n != start; n = at(n).next)
    grid_box_ = bounding_union(grid_box_, {p(n).x, p(n).y, p(n).x, p(n).y});
  const double span = std::max({grid_box_.width_mm(), grid_box_.height_mm(), 1e-9});
  const double largest_mm = std::max({std::abs(grid_box_.x0), std::abs(grid_box_.x1), std::abs(grid_box_.y0),
                                      std::abs(grid_box_.y1), span});
  min_ear_height_mm_ = 10 * largest_mm * std::numeric_limits<float>::epsilon();
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

bool EarClipper::is_ear(int b, double min_height_mm) const {
  const int a = nodes_[size_t(b)].prev, c = nodes_[size_t(b)].next;
  const Vec2 pa = p(a), pb = p(b), pc = p(c);
  const double twice_area = orient(pa, pb, pc);
  if (twice_area <= 0 || twice_area <= min_height_mm * norm(pc - pa)) return false;
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

int EarClipper::tallest_ear(int start) const {
  int best = start;
  double best_height = -1;
  int n = start;
  do {
    const Vec2 pa = p(nodes_[size_t(n)].prev), pc = p(nodes_[size_t(n)].next);
    const double height = orient(pa, p(n), pc) / std::max(norm(pc - pa), 1e-300);
    if (height > best_height && is_ear(n, 0.0)) best = n, best_height = height;
    n = nodes_[size_t(n)].next;
  } while (n != start);
  return best;
}

void EarClipper::clip_ears(int start, std::vector<std::array<int, 3>>& tris) {
  int count = 1;
  for (int n = at(start).next; n != start; n = at(n).next) ++count;
  build_grid(start, count);
  // Ears flatter than min_ear_height_mm_ are taken only when no other is
  // left: a sliver along a 12 mm base edge came out of float32 rounding
  // with its normal reversed, and one on a label with no area (the
  // MIL-STD-150A chart).
  int cur = start, misses = 0;
  while (count > 3) {
    if (misses > count) cur = tallest_ear(cur);  // no ear of min_ear_height_mm_ is left
    if (is_ear(cur, misses > count ? 0.0 : min_ear_height_mm_)) {
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
      if (++misses > 2 * count + 1) throw std::logic_error("relief mesh: ear clipping found no ear");
    }
  }
  const int a = at(cur).prev, c = at(cur).next;
  if (orient(p(a), p(cur), p(c)) <= 0)
    throw std::logic_error("relief mesh: a degenerate last triangle");
  tris.push_back({at(a).id, at(cur).id, at(c).id});
}

}  // namespace tactres::stl_detail
