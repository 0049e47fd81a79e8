#pragma once
// The outlines of the relief's raised regions (private to targets; used by
// relief_mesh in stl.cpp): input checks, the union of touching shapes, its
// boundary as closed loops, and the loops nested into faces with holes.

#include <utility>
#include <vector>

#include "stl_planar.h"
#include "tactres/targets/coverage.h"
#include "tactres/targets/layout.h"

namespace tactres::stl_detail {

// The mesh is only closed if shapes neither overlap nor reach the plate's
// edge; throws std::invalid_argument naming the shape(s) otherwise.
void check_shapes(const TargetLayout& L, const ArtworkIndex& index,
                  const std::vector<std::vector<Vec2>>& footprints);

// The directed edges bounding the union of the outlines (counter-clockwise
// point ids), region on the left. `neighbours[s]` lists the shapes that may
// touch shape s; `plate_height_mm` only turns mesh y back into target y in
// error messages.
std::vector<std::pair<int, int>> union_boundary(const std::vector<std::vector<int>>& outlines,
                                                const std::vector<std::vector<int>>& neighbours,
                                                const PointPool& pool, double plate_height_mm);

// Chains boundary edges into closed loops; throws std::invalid_argument
// where shapes meet at a single point.
std::vector<std::vector<int>> trace_loops(const std::vector<std::pair<int, int>>& edges,
                                          const std::vector<Vec2>& pts, double plate_height_mm);

// Drops points where a loop runs straight on.
void drop_straight_points(std::vector<std::vector<int>>& loops, const std::vector<Vec2>& pts);

struct Face {
  std::vector<int> outer;               // counter-clockwise
  std::vector<std::vector<int>> holes;  // clockwise
};

// Nests loops (material on the left) into faces with holes.
std::vector<Face> nest_faces(const std::vector<std::vector<int>>& loops, const std::vector<Vec2>& pts);

}  // namespace tactres::stl_detail
