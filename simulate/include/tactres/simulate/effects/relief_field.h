#pragma once
// The gel surface over a relief target: height and slope at any target
// point, in closed form. The relief is the layout's artwork raised by
// depth_fraction * relief_height_mm; the gel smooths it with a Gaussian of
// sigma_mm (ContactEffect). A Gaussian-smoothed rectangle is a product of
// erf differences, so height and slope are exact; discs are cut into thin
// rectangles of exactly the disc's strip areas.

#include <vector>

#include "tactres/targets/coverage.h"
#include "tactres/targets/layout.h"

namespace tactres {

class ReliefField {
 public:
  // Throws std::invalid_argument if the layout holds polygons (no closed form).
  ReliefField(const TargetLayout& layout, double sigma_mm, double peak_height_mm);

  struct Sample {
    double height_mm = 0;
    double slope_x = 0, slope_y = 0;  // df/dx, df/dy (dimensionless)
  };
  Sample at(Vec2 p_mm) const;

  double peak_height_mm() const { return height_mm_; }
  double sigma_mm() const { return sigma_mm_; }

 private:
  std::vector<ArtworkShape> rects_;
  ArtworkIndex index_;
  double sigma_mm_, height_mm_, reach_mm_;
};

}  // namespace tactres
