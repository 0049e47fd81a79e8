#pragma once
// Exact area coverage of artwork shapes. The raster emitter uses it on pixel
// squares, the simulator on pixel footprints mapped through a lens (convex
// quads), so it must be exact and cheap for small windows.

#include <span>
#include <utility>
#include <vector>

#include "tactres/targets/geometry.h"
#include "tactres/targets/layout.h"

namespace tactres {

// Area (mm^2) of `shape` inside `convex_polygon` (any winding, >= 3 vertices;
// fewer gives 0). Exact for every kind: rects and simple polygons are clipped,
// discs use the closed-form disc-triangle areas.
double intersection_area_mm2(const ArtworkShape& shape, std::span<const Vec2> convex_polygon);

// The same for an axis-aligned window, e.g. a pixel square.
double intersection_area_mm2(const ArtworkShape& shape, const RectMm& window);

// Area of a disc inside a convex polygon (any winding). Exact.
double disc_convex_polygon_area_mm2(Vec2 center_mm, double radius_mm,
                                    std::span<const Vec2> convex_polygon);

// Shoelace area: positive for counter-clockwise in a y-up frame (which is
// clockwise on screen, since the target frame has y down).
double signed_area_mm2(std::span<const Vec2> polygon);

// Uniform-grid bucketing of the artwork by bounds, so that a small query
// window only looks at the few shapes near it.
class ArtworkIndex {
 public:
  // `cell_mm` <= 0 picks a cell size from the shapes' extent and count.
  // The index refers to `shapes` by position; it does not keep a copy.
  explicit ArtworkIndex(std::span<const ArtworkShape> shapes, double cell_mm = 0.0);

  // Indices of the shapes whose bounds meet `window` (touching counts),
  // ascending, i.e. in drawing order. `out` is cleared first; reusing it
  // across calls avoids allocation. Thread-safe (const, no shared scratch).
  void query(const RectMm& window, std::vector<int>& out) const;
  std::vector<int> query(const RectMm& window) const;

  double cell_mm() const { return cell_mm_; }

 private:
  RectMm extent_;
  double cell_mm_ = 1.0;
  int nx_ = 0, ny_ = 0;
  std::vector<int> cell_begin_;  // CSR: shapes of cell c are items_[cell_begin_[c] .. [c+1])
  std::vector<int> items_;
  std::vector<RectMm> bounds_;
};

// Shapes with their index, owned together: the ideal pattern a profile is
// compared with (the layout's artwork in layout mode; one chart pattern and
// its detected neighbours in chart mode). Not copyable: the index refers to
// the shapes by position.
class IndexedArtwork {
 public:
  explicit IndexedArtwork(std::vector<ArtworkShape> shapes, double cell_mm = 0.0)
      : shapes_(std::move(shapes)), index_(shapes_, cell_mm) {}
  IndexedArtwork(const IndexedArtwork&) = delete;
  IndexedArtwork& operator=(const IndexedArtwork&) = delete;

  const std::vector<ArtworkShape>& shapes() const { return shapes_; }
  const ArtworkIndex& index() const { return index_; }

 private:
  std::vector<ArtworkShape> shapes_;
  ArtworkIndex index_;
};

}  // namespace tactres
