#pragma once
// The level of a profile bin some of whose pixels were clipped at black.
//
// Contract: `values` are one bin's pixel values (linear light), those at or
// below 0 clipped there (the sensor or the file could not go lower: each
// says only that its light was at or below black's). The pixels are taken
// as Gaussian about the bin's level, and the clipped ones as censored at
// 0 (the Tobit model): the level and the spread are that likelihood's
// maximum, and the level's standard error comes from its curvature there
// (both parameters free). Every bin is estimated alike, however many of its
// pixels clipped: choosing the bins by how few clipped would choose those
// whose noise drew high (a 40 % cut read m 0.012 high on the reference
// renderer's negative chart). nullopt where the bin cannot say: fewer than
// kMinUnclippedPixels unclipped, no spread among them (one code value,
// whose error is its quantisation), or no maximum found.

#include <optional>
#include <vector>

namespace tactres::profiles_detail {

constexpr int kMinUnclippedPixels = 8;

struct CensoredLevel {
  double value = 0;     // the level, linear light
  double sigma = 0;     // its standard error
  double sigma_px = 0;  // the per-pixel spread
};

std::optional<CensoredLevel> level_clipped_at_black(const std::vector<double>& values);

}  // namespace tactres::profiles_detail
