// The relief mesh: options, the mesh's volume, shape footprints, and
// relief_mesh, which assembles the closed mesh from the region outlines
// (stl_outlines.cpp) and their triangulated faces (stl_ear_clipper.cpp).
// Writing STL files is in stl_write.cpp.
#include "tactres/targets/stl.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <stdexcept>
#include <unordered_map>

#include <fmt/format.h>

#include "stl_ear_clipper.h"
#include "stl_outlines.h"
#include "stl_planar.h"
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

TriangleMesh relief_mesh(const TargetLayout& L, const StlOptions& options) {
  using namespace stl_detail;  // the mesh's parts: stl_planar.h, stl_outlines.h, stl_ear_clipper.h
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

}  // namespace tactres
