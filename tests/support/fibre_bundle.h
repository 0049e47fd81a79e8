#pragma once
// Test support (unit and end-to-end tests): a coherent fibre bundle's
// transmission, the honeycomb it lays over a relayed image (dev_01, dev_02).

#include <cmath>

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

}  // namespace tactres::testing
