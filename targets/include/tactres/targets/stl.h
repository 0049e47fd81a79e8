#pragma once
// The relief as a closed, printable triangle mesh (binary STL): a base plate
// with every artwork shape raised on top of it.
//
// Mesh frame: x_mesh = x, y_mesh = height_mm - y, z up. The plate's bottom
// is z = 0, the ground is z = base_thickness_mm and raised tops are at
// base_thickness_mm + relief_height_mm. This is a proper rotation of the
// target frame (whose z points into the target), so seen from +z the relief
// reads like the printed target, not mirrored.

#include <array>
#include <filesystem>
#include <string_view>
#include <vector>

#include "tactres/targets/geometry.h"

#include "tactres/targets/layout.h"

namespace tactres {

struct StlOptions {
  int disc_segments = 96;  // discs become regular N-gons inscribed in the circle, N in [8, 4096]

  // Throws std::invalid_argument naming the option and its range.
  void validate() const;
};

// Vertices are shared by index; triangles wind counter-clockwise seen from
// outside, so normals point out.
struct TriangleMesh {
  std::vector<Vec3> vertices;
  std::vector<std::array<int, 3>> triangles;

  double volume_mm3() const;  // divergence theorem; > 0 for outward winding
};

// Footprint of a shape as meshed, in the target frame (discs as N-gons).
std::vector<Vec2> mesh_footprint_mm(const ArtworkShape& shape, const StlOptions& options);

// Builds one closed 2-manifold: shapes that touch are merged into one raised
// region, and the ground and raised faces are triangulated with the region
// outlines as holes, so every edge is shared by exactly two triangles (no
// T-junctions). Throws std::invalid_argument if shapes overlap or do not lie
// strictly inside the field.
TriangleMesh relief_mesh(const TargetLayout& layout, const StlOptions& options = {});

// Binary STL, written atomically. Throws std::runtime_error naming the path.
void write_binary_stl(const std::filesystem::path& path, const TriangleMesh& mesh,
                      std::string_view header = "tactres relief (mm)");

void write_relief_stl(const std::filesystem::path& path, const TargetLayout& layout,
                      const StlOptions& options = {});

}  // namespace tactres
