#include "chart_frames.h"

#include <cmath>
#include <random>

#include <doctest/doctest.h>

namespace tactres::chart {
namespace {

// A dark-bar triplet's profile (bars w_mm wide at -2w, 0, 2w, moved by
// shift_mm along u), level 1 with bars at 0.6, blurred by a Gaussian of
// 0.4 w, binned at w/5 over +-4 w, with white noise of sd noise_sd.
ProfileData triplet_profile(double w_mm, double shift_mm, double noise_sd, std::mt19937& rng) {
  ProfileData d;
  d.bin_mm = 0.2 * w_mm;
  d.u0_mm = -4 * w_mm;
  d.bin_count = 40;
  d.fit_begin = 0;
  d.fit_end = d.bin_count;
  std::normal_distribution<double> noise(0, noise_sd);
  const double s = 0.4 * w_mm * std::sqrt(2.0);
  for (int b = 0; b < d.bin_count; ++b) {
    const double u = d.bin_center_mm(b);
    double bar = 0;
    for (int k = -1; k <= 1; ++k) {
      const double c = 2 * k * w_mm + shift_mm;
      bar += 0.5 * (std::erf((u - c + 0.5 * w_mm) / s) - std::erf((u - c - 0.5 * w_mm) / s));
    }
    d.u_mean_mm.push_back(u);
    d.value.push_back(1 - 0.4 * bar + (noise_sd > 0 ? noise(rng) : 0));
    d.count.push_back(4);
    d.sigma.push_back(noise_sd > 0 ? noise_sd : 0.01);
  }
  return d;
}

// Four patterns of one nested group (bars 2.4, 2.1, 1.9 and 1.7 px wide at
// 40 px/mm), all placed `offset_px` off along the group's common direction;
// the second one's u runs the other way.
struct Group {
  std::vector<ProfileData> data;
  std::vector<ShiftSample> samples;
};

Group misplaced_group(double offset_px, double noise_sd, unsigned seed) {
  std::mt19937 rng(seed);
  Group g;
  const double px_per_mm = 40;
  const double bar_px[] = {2.4, 2.1, 1.9, 1.7};
  const double sign[] = {1, -1, 1, 1};
  for (int i = 0; i < 4; ++i) {
    const double w_mm = bar_px[i] / px_per_mm;
    // The pattern lies offset_px away: at u = sign * offset / scale.
    g.data.push_back(triplet_profile(w_mm, sign[i] * offset_px / px_per_mm, noise_sd, rng));
  }
  for (int i = 0; i < 4; ++i) g.samples.push_back({&g.data[i], bar_px[i] / px_per_mm, sign[i] / px_per_mm});
  return g;
}

TEST_CASE("common_shift_px: a group placed 1.5 bars off is moved onto its bars, whichever way each u runs") {
  for (const double offset_px : {-3.0, -1.5, 2.0}) {
    CAPTURE(offset_px);
    const Group g = misplaced_group(offset_px, 0.01, 1);
    const std::optional<double> s = common_shift_px(g.samples, false, 1.5 * 2.4);
    REQUIRE(s);
    CHECK(std::abs(*s - offset_px) <= 0.15);  // a step and a half
  }
}

TEST_CASE("common_shift_px: no shift where the patterns are in place, or show no bars") {
  // In place: nothing to gain over where they are.
  CHECK_FALSE(common_shift_px(misplaced_group(0.0, 0.01, 2).samples, false, 3.6));
  // Only noise: whatever shift it likes best is no group's.
  for (unsigned seed = 3; seed < 103; ++seed) {
    CAPTURE(seed);
    Group g = misplaced_group(0.0, 0.05, seed);
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0, 0.05);
    for (ProfileData& d : g.data)
      for (double& v : d.value) v = 1 + noise(rng);
    CHECK_FALSE(common_shift_px(g.samples, false, 3.6));
  }
}

}  // namespace
}  // namespace tactres::chart
