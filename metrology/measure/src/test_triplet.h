#pragma once
// Tests only: the layout and ideal artwork of one vertical-bar triplet,
// bars w_mm wide about the plane's origin, 5 w_mm long.

#include <vector>

#include "tactres/targets/layout.h"

namespace tactres::test {

struct TripletLayout {
  ElementLayout element;
  std::vector<ArtworkShape> shapes;  // its three bars, for an IndexedArtwork
};

inline TripletLayout vertical_triplet(double w_mm) {
  TripletLayout t;
  ElementLayout& e = t.element;
  e.bar_width_mm = w_mm;
  e.lp_per_mm = 0.5 / w_mm;
  e.orientation = BarOrientation::vertical_bars;
  for (int k = -1; k <= 1; ++k) {
    e.bars_mm[k + 1] = {(2 * k - 0.5) * w_mm, -2.5 * w_mm, (2 * k + 0.5) * w_mm, 2.5 * w_mm};
    t.shapes.push_back({ArtworkShape::Kind::rect, ArtworkShape::Role::bar, e.bars_mm[k + 1], {}, 0, {}});
  }
  return t;
}

}  // namespace tactres::test
