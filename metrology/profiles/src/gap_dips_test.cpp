#include "tactres/profiles/gap_dips.h"

#include <cmath>

#include <doctest/doctest.h>

#include "tactres/profiles/profile_sampler.h"

namespace tactres {

namespace {

constexpr double kBarMm = 0.1;

// A triplet of bars 0.1 mm wide at u = -0.2, 0, 0.2 on 0.01 mm bins, each
// bin 4 samples of standard error `se`: bars at `bar_level`, gaps at
// gap_level[k], the ground beyond at `ground`. Dark bars unless `light`
// (then the ideal is complemented, as the sampler does for a negative
// chart).
ProfileData triplet(double bar_level, const double gap_level[2], double ground, double se, bool light) {
  ProfileData d;
  d.bin_mm = 0.01;
  d.bin_count = 80;
  d.u0_mm = -0.4;
  d.fit_begin = 0;
  d.fit_end = d.bin_count;
  for (int i = 0; i < 3; ++i) d.ideal.push_back({(i - 1) * 0.2 - 0.05, (i - 1) * 0.2 + 0.05, 1.0});
  if (light) complement_ideal(d);
  for (int b = 0; b < d.bin_count; ++b) {
    const double u = d.bin_center_mm(b);
    double v = ground;
    for (int i = 0; i < 3; ++i)
      if (std::abs(u - (i - 1) * 0.2) < 0.05) v = bar_level;
    if (u > -0.15 && u < -0.05) v = gap_level[0];
    if (u > 0.05 && u < 0.15) v = gap_level[1];
    d.value.push_back(v);
    d.u_mean_mm.push_back(u);
    d.sigma.push_back(se);
    d.count.push_back(4);
  }
  return d;
}

}  // namespace

TEST_CASE("gap dips: a clean triplet dips at both gaps, either polarity") {
  const double gaps[2] = {0.8, 0.8};
  const GapDips dark = gap_dips(triplet(0.2, gaps, 0.8, 0.01, false), kBarMm, -0.9);
  REQUIRE(dark.valid);
  CHECK(dark.dip[0] == doctest::Approx(0.6));
  CHECK(dark.dip[1] == doctest::Approx(0.6));
  // Two windows of 4-6 bins of standard error 0.01 each.
  CHECK(dark.sigma[0] > 0.01 * std::sqrt(2.0 / 6));
  CHECK(dark.sigma[0] < 0.01 * std::sqrt(2.0 / 4) + 1e-12);
  CHECK_FALSE(dark.flat_gap());
  CHECK(dark.three_bars());
  CHECK(dark.ground == doctest::Approx(0.8));  // beside the triplet
  const double light_gaps[2] = {0.2, 0.2};
  const GapDips light = gap_dips(triplet(0.8, light_gaps, 0.2, 0.01, true), kBarMm, -0.9);
  REQUIRE(light.valid);
  CHECK(light.dip[0] == doctest::Approx(0.6));
  CHECK(light.dip[1] == doctest::Approx(0.6));
}

TEST_CASE("gap dips: a gap filled to the bars' level is flat while the other dips") {
  const double gaps[2] = {0.8, 0.21};
  const GapDips g = gap_dips(triplet(0.2, gaps, 0.8, 0.01, false), kBarMm, -0.9);
  REQUIRE(g.valid);
  CHECK(g.dip[1] == doctest::Approx(0.01));
  CHECK(g.flat_gap() == std::optional<int>(1));
  CHECK_FALSE(g.three_bars());
  // The wrong polarity turns every dip negative: the data then show no bars
  // at all, which is the model's business (both dips fail the 5 sigma test).
  CHECK_FALSE(gap_dips(triplet(0.2, gaps, 0.8, 0.01, false), kBarMm, 0.9).flat_gap());
}

TEST_CASE("gap dips: a gap dipping significantly but under a tenth of the other is flat") {
  // Small bin errors (a JPEG's smoothing): the first gap dips 0.03, many
  // sigma, while the second dips 0.6.
  const double gaps[2] = {0.23, 0.8};
  const GapDips g = gap_dips(triplet(0.2, gaps, 0.8, 0.002, false), kBarMm, -0.9);
  REQUIRE(g.valid);
  CHECK(g.dip[0] > 5 * g.sigma[0]);
  CHECK(g.flat_gap() == std::optional<int>(0));
  // A fifth of the other's: a gap, as a reader sees one (dev_04's G6E5 H).
  const double fifth[2] = {0.32, 0.8};
  CHECK_FALSE(gap_dips(triplet(0.2, fifth, 0.8, 0.002, false), kBarMm, -0.9).flat_gap());
}

TEST_CASE("gap dips: the windows follow a triplet placed a third of a bar off") {
  const double gaps[2] = {0.8, 0.8};
  ProfileData d = triplet(0.2, gaps, 0.8, 0.01, false);
  for (IdealBox& b : d.ideal) b.u0_mm += 0.033, b.u1_mm += 0.033;
  const GapDips g = gap_dips(d, kBarMm, -0.9);
  REQUIRE(g.valid);
  CHECK(g.dip[0] == doctest::Approx(0.6));
  CHECK(g.dip[1] == doctest::Approx(0.6));
  CHECK_FALSE(g.flat_gap());
}

TEST_CASE("gap dips: two shallow gaps are left to the model") {
  // Both dips under 2 sigma: neither shows the other could dip.
  const double gaps[2] = {0.205, 0.205};
  const GapDips g = gap_dips(triplet(0.2, gaps, 0.8, 0.01, false), kBarMm, -0.9);
  REQUIRE(g.valid);
  CHECK(g.dip[0] < 2 * g.sigma[0]);
  CHECK_FALSE(g.flat_gap());
  CHECK_FALSE(g.three_bars());
}

TEST_CASE("gap dips: an empty or clipped window gives no verdict") {
  const double gaps[2] = {0.8, 0.21};
  ProfileData d = triplet(0.2, gaps, 0.8, 0.01, false);
  ProfileData empty = d;
  for (int b = 0; b < empty.bin_count; ++b)
    if (std::abs(empty.u_mean_mm[b] - 0.1) < 0.08) empty.count[b] = 0;
  CHECK_FALSE(gap_dips(empty, kBarMm, -0.9).valid);
  // A gap clipped at black could have been darker still: no verdict. One
  // clipped at saturation was at least that bright, so its dip at least
  // what it reads: it counts.
  ProfileData clipped = d;
  clipped.bound.assign(clipped.bin_count, 0);
  for (int b = 0; b < clipped.bin_count; ++b)
    if (std::abs(clipped.u_mean_mm[b] - 0.1) < 0.08) clipped.bound[b] = -1;
  CHECK_FALSE(gap_dips(clipped, kBarMm, -0.9).valid);
  for (signed char& b : clipped.bound) b = b == -1 ? 1 : 0;
  CHECK(gap_dips(clipped, kBarMm, -0.9).flat_gap() == std::optional<int>(1));
  // Without three bars of the given width the triplet is not found.
  CHECK_FALSE(gap_dips(d, 2 * kBarMm, -0.9).valid);
}

TEST_CASE("gap dips: at under 2 px per bar the windows widen to a pixel, so a frame aligned with the bars is read") {
  // One sample per 0.08 mm pixel (1.25 px per bar), every pixel at the same
  // phase: half-bar windows miss a gap or a bar at every shift.
  const double gaps[2] = {0.8, 0.8};
  ProfileData d = triplet(0.2, gaps, 0.8, 0.01, false);
  for (int b = 0; b < d.bin_count; ++b)
    if (b % 8 != 0) d.count[b] = 0;
  CHECK_FALSE(gap_dips(d, kBarMm, -0.9).valid);
  const GapDips g = gap_dips(d, kBarMm, -0.9, 0.08);
  CHECK(g.valid);
  // At 2 px per bar or more the pixel changes nothing.
  const ProfileData dense = triplet(0.2, gaps, 0.8, 0.01, false);
  CHECK(gap_dips(dense, kBarMm, -0.9, 0.05).dip[0] == doctest::Approx(gap_dips(dense, kBarMm, -0.9).dip[0]));
  CHECK(gap_dips(dense, kBarMm, -0.9, 0.05).sigma[0] == doctest::Approx(gap_dips(dense, kBarMm, -0.9).sigma[0]));
}

}  // namespace tactres
