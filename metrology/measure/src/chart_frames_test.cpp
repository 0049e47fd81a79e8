#include "chart_frames.h"

#include <cmath>
#include <random>

#include <doctest/doctest.h>
#include <opencv2/imgproc.hpp>

namespace tactres::chart {
namespace {

struct ProfileSpec {
  double bar_px = 2;
  double offset_px = 0;       // where the pattern lies, px along u
  double contrast = 0.4;      // 0: no bars
  bool light = false;         // light bars on a dark ground
  double noise_sd = 0.01;     // per bin mean
  double bin_px = 0.4;
  int filled_every = 1;       // 4 at bins of 0.25 px: one pixel column in every fourth bin
  double half_bars = 4;       // the profile's reach either way, bar widths
  double blur_bars = 0.4;     // the Gaussian's sigma, bar widths
};

// A triplet's profile at 40 px/mm (bars at -2w, 0, 2w moved by offset_px),
// ground 1, blurred by a Gaussian of blur_bars, over +-half_bars, with
// white noise on the filled bins.
ProfileData triplet_profile(const ProfileSpec& p, std::mt19937& rng) {
  constexpr double kPxPerMm = 40;
  const double w_mm = p.bar_px / kPxPerMm, shift_mm = p.offset_px / kPxPerMm;
  ProfileData d;
  d.bin_mm = p.bin_px / kPxPerMm;
  d.bin_count = static_cast<int>(std::ceil(2 * p.half_bars * w_mm / d.bin_mm));
  d.u0_mm = -0.5 * d.bin_count * d.bin_mm;
  d.fit_begin = 0;
  d.fit_end = d.bin_count;
  std::normal_distribution<double> noise(0, p.noise_sd);
  const double s = p.blur_bars * w_mm * std::sqrt(2.0);
  for (int b = 0; b < d.bin_count; ++b) {
    const double u = d.bin_center_mm(b);
    double bar = 0;
    for (int k = -1; k <= 1; ++k) {
      const double c = 2 * k * w_mm + shift_mm;
      bar += 0.5 * (std::erf((u - c + 0.5 * w_mm) / s) - std::erf((u - c - 0.5 * w_mm) / s));
    }
    const bool filled = b % p.filled_every == 0;
    d.u_mean_mm.push_back(u);
    d.value.push_back(filled ? (p.light ? 0.6 + p.contrast * bar : 1 - p.contrast * bar) + noise(rng) : NAN);
    d.count.push_back(filled ? 6 : 0);
    d.sigma.push_back(filled ? p.noise_sd : 1.0);
  }
  return d;
}

// Four patterns of one nested group (bars 2.4, 2.1, 1.9 and 1.7 px wide),
// placed `offset_px` off along the group's common direction; the u of the
// second and third runs the other way. `bars[i]`: whether pattern i shows
// bars.
struct Group {
  std::vector<ProfileData> data;
  std::vector<ShiftSample> samples;
};

Group group_of(ProfileSpec spec, std::array<bool, 4> bars, unsigned seed) {
  std::mt19937 rng(seed);
  Group g;
  const double bar_px[] = {2.4, 2.1, 1.9, 1.7};
  const double sign[] = {1, -1, -1, 1};
  const double offset_px = spec.offset_px, contrast = spec.contrast;
  for (int i = 0; i < 4; ++i) {
    spec.bar_px = bar_px[i];
    spec.offset_px = sign[i] * offset_px;
    spec.contrast = bars[i] ? contrast : 0;
    g.data.push_back(triplet_profile(spec, rng));
  }
  for (int i = 0; i < 4; ++i) g.samples.push_back({&g.data[i], bar_px[i] / 40, sign[i] / 40});
  return g;
}

constexpr std::array<bool, 4> kAllBars{true, true, true, true};

TEST_CASE("shared_shifts_px: a group placed a bar off is moved onto its bars, whichever way each u runs") {
  for (const bool light : {false, true})
    for (const double offset_px : {-3.0, -1.5, 2.0}) {
      CAPTURE(light);
      CAPTURE(offset_px);
      ProfileSpec spec;
      spec.offset_px = offset_px;
      spec.light = light;
      const Group g = group_of(spec, kAllBars, 1);
      const auto shifts = shared_shifts_px(g.samples, light, 1.5 * 2.4);
      for (const auto& s : shifts) {
        REQUIRE(s);
        CHECK(std::abs(*s - offset_px) <= 0.15);  // a step and a half
      }
    }
}

TEST_CASE("shared_shifts_px: each pattern is moved by the others' shift, not by its own noise") {
  // The fourth pattern shows no bars: it moves with the rest, to where its
  // bars would be, not to where its noise fits best.
  ProfileSpec spec;
  spec.offset_px = 2.0;
  for (unsigned seed = 1; seed < 21; ++seed) {
    CAPTURE(seed);
    const Group g = group_of(spec, {true, true, true, false}, seed);
    const auto shifts = shared_shifts_px(g.samples, false, 3.6);
    REQUIRE(shifts[3]);
    CHECK(std::abs(*shifts[3] - 2.0) <= 0.15);
    // Its own data do not place it: other noise gives the same shift.
    Group other = group_of(spec, {true, true, true, false}, seed);
    std::mt19937 rng(seed + 1000);
    ProfileSpec own = spec;
    own.bar_px = 1.7;
    own.contrast = 0;
    own.noise_sd = 0.03;
    other.data[3] = triplet_profile(own, rng);
    const auto other_shifts = shared_shifts_px(other.samples, false, 3.6);
    CHECK((!other_shifts[3] || *other_shifts[3] == *shifts[3]));
    // One pattern with bars among three without: a pattern may be moved to
    // where those bars are, never elsewhere.
    const auto one = shared_shifts_px(group_of(spec, {true, false, false, false}, seed).samples, false, 3.6);
    for (size_t i = 0; i < 4; ++i) {
      CAPTURE(i);
      CAPTURE(one[i].value_or(-99));
      CHECK((!one[i] || std::abs(*one[i] - 2.0) <= 0.6));  // a quarter bar
    }
  }
}

TEST_CASE("shared_shifts_px: no shift where the patterns are in place, or show no bars") {
  // In place: nothing to gain over where they are.
  for (const auto& s : shared_shifts_px(group_of(ProfileSpec{}, kAllBars, 2).samples, false, 3.6)) CHECK_FALSE(s);
  // Only noise, white per bin, or a pixel column in every fourth bin of a
  // chart square to the pixel grid (a half-bar window holds 0-2 bins):
  // whatever shift it likes best is no group's.
  for (const int filled_every : {1, 4}) {
    ProfileSpec spec;
    spec.contrast = 0;
    spec.noise_sd = 0.05;
    spec.filled_every = filled_every;
    spec.bin_px = filled_every == 1 ? 0.4 : 0.25;
    for (unsigned seed = 3; seed < 303; ++seed) {
      CAPTURE(filled_every);
      CAPTURE(seed);
      for (const auto& s : shared_shifts_px(group_of(spec, {false, false, false, false}, seed).samples, false, 3.6))
        CHECK_FALSE(s);
    }
  }
}

}  // namespace
}  // namespace tactres::chart

TEST_CASE("scale field: a pattern far from samples along one column keeps its own scale") {
  // Eight samples along x = 100..103 px, their scale falling gently down
  // the column, with a little noise across it: the plane's tilt across x
  // is set by that noise alone.
  std::vector<std::pair<tactres::Vec2, double>> samples;
  for (int k = 0; k < 8; ++k)
    samples.push_back({{100.0 + (k % 4), 50.0 + 60 * k}, 20.0 * (1 - 0.002 * k) * (k % 2 ? 1.01 : 0.99)});
  const tactres::chart::ScaleField f = tactres::chart::fit_scale_field(samples);
  REQUIRE(f.valid);
  CHECK(f.at_or({101, 200}, 19.5) == doctest::Approx(f.at({101, 200})));  // among the samples: the field
  CHECK(f.at({101, 200}) == doctest::Approx(19.9).epsilon(0.02));
  const tactres::Vec2 far{600, 200};
  CHECK(std::abs(std::log(f.at(far) / 20.0)) > 1);  // the plane has strayed by e times or more
  CHECK(f.at_or(far, 19.0) == 19.0);                // the pattern's own scale stands
}

TEST_CASE("period_slip: a triplet one period off is seen there, a centred one stays, however blurred") {
  using namespace tactres::chart;
  std::mt19937 rng(7);
  for (const bool light : {false, true})
    for (const double blur_bars : {0.4, 1.0}) {
      ProfileSpec spec;
      spec.bar_px = 3;
      spec.light = light;
      spec.half_bars = 6;
      spec.blur_bars = blur_bars;
      const double w_mm = spec.bar_px / 40;
      CAPTURE(light);
      CAPTURE(blur_bars);
      for (const int slip : {-1, 0, 1}) {
        spec.offset_px = 2 * slip * spec.bar_px;
        CHECK(period_slip(triplet_profile(spec, rng), w_mm, light) == slip);
      }
      // A bar off is no period off: that is the correlation centring's to move.
      spec.offset_px = spec.bar_px;
      CHECK(period_slip(triplet_profile(spec, rng), w_mm, light) == 0);
      // No bars: nothing to move to.
      spec.offset_px = 2 * spec.bar_px;
      spec.contrast = 0;
      CHECK(period_slip(triplet_profile(spec, rng), w_mm, light) == 0);
    }
}

TEST_CASE("PlacementStore::unslipped: a frame a period off its triplet is moved onto it, one on it stays") {
  using namespace tactres;
  using namespace tactres::chart;
  // A vertical-bar triplet, 4 px per bar, dark bars (0.3) on ground 1 at x
  // 92, 100 and 108 px, 20 px long, blurred by a Gaussian of 1 px; its
  // element at 1 lp/mm, so 8 px per mm. Its H partner stands 3.5 periods
  // to the right, within the reach of the windows one period along.
  cv::Mat lum(200, 200, CV_32F, cv::Scalar(1.0));
  for (const int c : {92, 100, 108}) {
    lum(cv::Rect(c - 2, 90, 4, 20)).setTo(0.3);
    lum(cv::Rect(118, c - 2, 20, 4)).setTo(0.3);
  }
  cv::GaussianBlur(lum, lum, {0, 0}, 1.0);
  for (const double found_x : {108.0, 92.0, 100.0}) {
    CAPTURE(found_x);
    ChartDetection D;
    BarPattern p;
    p.center_px = {found_x, 100};
    p.bar_dir = {0, 1};
    p.period_px = 8;
    p.bar_length_px = 20;
    D.patterns.push_back(p);
    const PatternRef r{0, BarOrientation::vertical_bars, 0, 1, 1.0, false};
    const PlacementStore store(lum, D, 2.0);
    const PatternFrame f = frame_of(p, r.orientation, r.lp_per_mm);
    const std::optional<PatternFrame> moved = store.unslipped(r, f, ProfileSamplingOptions{});
    if (found_x == 100.0) {
      CHECK_FALSE(moved);
    } else {
      REQUIRE(moved);
      CHECK(moved->center_px.x == doctest::Approx(100).epsilon(0.004));  // within 0.4 px
      CHECK(moved->center_px.y == doctest::Approx(100));
    }
  }
}
