#pragma once
// Planar points of the relief mesh (private to targets; relief_mesh in
// stl.cpp and its parts in stl_outlines.cpp and stl_ear_clipper.cpp).
// Coordinates are snapped to 2^-30 mm (exact in a double) so that shapes
// meant to touch share vertices exactly; a point's id is its identity
// everywhere (loops, faces, walls).

#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "tactres/targets/geometry.h"

namespace tactres::stl_detail {

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

inline double orient(Vec2 a, Vec2 b, Vec2 c) { return cross(b - a, c - a); }

// A directed edge a -> b as one map key; (b, a) is its twin.
inline std::uint64_t edge_key(int a, int b) {
  return (std::uint64_t(std::uint32_t(a)) << 32) | std::uint32_t(b);
}

}  // namespace tactres::stl_detail
