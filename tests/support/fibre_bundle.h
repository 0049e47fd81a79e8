#pragma once
// Test support (unit and end-to-end tests): a coherent fibre bundle's
// transmission, the honeycomb it lays over a relayed image (dev_01, dev_02).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include <opencv2/core.hpp>

namespace tactres::testing {

// At image pixel (x, y): bright cores (Gaussian, sigma 1 px) on a
// hexagonal lattice of `period_px` (rows offset by half a period) over a
// dark net of `net`.
inline double fibre_transmission(double x, double y, double period_px, double net = 0.25) {
  const double row_px = period_px * std::sqrt(3.0) / 2;
  double t = net;
  const int r0 = static_cast<int>(std::floor(y / row_px));
  for (int r = r0 - 1; r <= r0 + 2; ++r) {
    const double cy = r * row_px, shift = (r % 2 != 0) ? 0.5 * period_px : 0;
    const int c0 = static_cast<int>(std::floor((x - shift) / period_px));
    for (int c = c0 - 1; c <= c0 + 2; ++c) {
      const double cx = c * period_px + shift;
      t += 1.5 * std::exp(-((x - cx) * (x - cx) + (y - cy) * (y - cy)) / 2.0);
    }
  }
  return t;
}

// A real bundle is fused from multi-fibres whose lattices are turned a
// little against each other: its spectrum shows a ring with six peaks
// (dev_01, dev_02), where one perfect lattice shows six sharp peaks only.
// Here `domains` cells (the pixels nearest to random points over a
// width x height image), each lattice turned by turn_deg +- 8 degrees and
// shifted; spacing_px as in fibre_transmission.
class FibreBundle {
 public:
  FibreBundle(double spacing_px, double turn_deg, int width, int height, int domains = 12, std::uint64_t seed = 1)
      : spacing_px_(spacing_px) {
    cv::RNG rng(seed);
    for (int k = 0; k < domains; ++k) {
      const double a = (turn_deg + rng.uniform(-8.0, 8.0)) * std::numbers::pi / 180;
      domains_.push_back({rng.uniform(0.0, double(width)), rng.uniform(0.0, double(height)), std::cos(a),
                          std::sin(a), rng.uniform(0.0, spacing_px), rng.uniform(0.0, spacing_px)});
    }
  }
  double transmission(double x, double y) const {
    const Domain* d = &domains_.front();
    for (const Domain& e : domains_)
      if (std::hypot(x - e.x, y - e.y) < std::hypot(x - d->x, y - d->y)) d = &e;
    return fibre_transmission(d->c * x - d->s * y + d->dx, d->s * x + d->c * y + d->dy, spacing_px_);
  }
  // The rows of cores stand this far apart.
  double row_pitch_px() const { return spacing_px_ * std::sqrt(3.0) / 2; }

 private:
  struct Domain {
    double x, y, c, s, dx, dy;
  };
  double spacing_px_;
  std::vector<Domain> domains_;
};

}  // namespace tactres::testing
