#include "chart_level_step.h"

#include <cmath>
#include <random>

#include <doctest/doctest.h>

using namespace tactres;

namespace {

// Three bars of width w (mm) centred on 0 in the ideal (at `shift_mm` in
// the data), the ground lit by a ramp 1 + 0.1 u, ink at (1 + c) times the
// ground, smoothed by a box of half-width `blur_mm`, with relative noise
// `noise`, in bins of w / 20.
ProfileData three_bars(double c, double w, double blur_mm, double noise, unsigned seed, double shift_mm = 0) {
  ProfileData d;
  d.bin_mm = w / 20;
  d.bin_count = 200;
  d.u0_mm = -0.5 * d.bin_count * d.bin_mm;
  for (int k = -1; k <= 1; ++k) d.ideal.push_back({(2 * k - 0.5) * w, (2 * k + 0.5) * w, 1.0});
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int b = 0; b < d.bin_count; ++b) {
    const double u = d.bin_center_mm(b);
    double s = 0;
    for (int j = -10; j <= 10; ++j) s += d.ideal_at(u - shift_mm + blur_mm * j / 10) / 21;
    d.value.push_back((1 + 0.1 * u) * (1 + c * s) * (1 + noise * n(rng)));
    d.u_mean_mm.push_back(u);
    d.sigma.push_back(noise);
    d.count.push_back(100);
  }
  d.fit_begin = 0;
  d.fit_end = d.bin_count;
  return d;
}

// n coarse found patterns of group `group` element 1 at `lp_per_mm`,
// alternately H and V, pattern k sampled as profile(k): what
// chart_level_steps takes.
struct CoarsePatterns {
  ChartDetection D;
  std::vector<chart::PatternRef> refs;
  std::vector<ElementJob> jobs;
  std::vector<std::vector<SampledProfile>> profiles;
};
template <class Profile>
CoarsePatterns coarse_patterns(int n, int group, double lp_per_mm, Profile profile) {
  CoarsePatterns c;
  c.D.patterns.resize(n);
  for (int k = 0; k < n; ++k) {
    const auto o = k % 2 ? BarOrientation::vertical_bars : BarOrientation::horizontal_bars;
    c.refs.push_back({k, o, group, 1, lp_per_mm});
    ElementJob job;
    job.element = ElementResult::of(group, 1, o, lp_per_mm, 10.0);
    c.jobs.push_back(job);
    SampledProfile p;
    p.data = profile(k);
    p.in_view = true;
    p.pixels_used = 1000;
    c.profiles.push_back({p});
  }
  return c;
}

}  // namespace

TEST_CASE("chart level step: read off the plateaus of wide bars under a light ramp and blur") {
  for (const double c : {-0.97, -0.5, 0.8}) {
    CAPTURE(c);
    // Blur up to a quarter bar leaves the plateaus alone.
    const auto s = chart::plateau_level_step(three_bars(c, 1.0, 0.2, 0.002, 1), 1.0);
    REQUIRE(s);
    CHECK(s->contrast == doctest::Approx(c).epsilon(0.01));
    CHECK(s->contrast_sigma > 0);
    CHECK(std::abs(s->contrast - c) < 4 * s->contrast_sigma + 1e-3);
  }
  // Blur wider than half a bar reaches the middles: the step reads smaller
  // (which is why it is only a fallback for wide, sharp bars).
  const auto soft = chart::plateau_level_step(three_bars(-0.9, 1.0, 0.8, 0.0, 1), 1.0);
  REQUIRE(soft);
  CHECK(std::abs(soft->contrast) < 0.89);
}

TEST_CASE("chart level step: no plateaus, no step") {
  ProfileData d = three_bars(-0.9, 1.0, 0.1, 0.0, 1);
  // Only the middle of the profile: one bar and no ground on both sides.
  d.fit_begin = 90;
  d.fit_end = 110;
  CHECK_FALSE(chart::plateau_level_step(d, 1.0));
  // All bins empty.
  ProfileData e = three_bars(-0.9, 1.0, 0.1, 0.0, 1);
  for (int& n : e.count) n = 0;
  CHECK_FALSE(chart::plateau_level_step(e, 1.0));
}

TEST_CASE("chart level step: coarse patterns that all clip are refused, and the problem says so") {
  CoarsePatterns c = coarse_patterns(2, -1, 0.5, [](int) { return three_bars(-0.9, 1.0, 0.1, 0.002, 1); });
  // The ground clipped at saturation: bins that stay bounds (a bin clipped
  // at black alone is read past the clipping where it can be, and a
  // pattern left with no bound then counts as measured).
  for (auto& p : c.profiles) {
    ProfileData& d = p.front().data;
    d.bound.assign(d.bin_count, 0);
    for (int b = 0; b < d.bin_count; ++b)
      if (d.value[b] >= 0.99) d.bound[b] = 1;
    p.front().pixels_clipped = 300;
  }
  ReferenceResult ref;
  std::string note;
  CHECK_FALSE(chart::chart_level_steps(c.D, c.refs, c.jobs, c.profiles, MeasureOptions{}, ref, &note));
  CHECK(note.find("2 of the 2 coarse pattern(s)") != std::string::npos);
  CHECK(note.find("clipped") != std::string::npos);
  // Unclipped, the same patterns give the step.
  for (auto& p : c.profiles) p.front().pixels_clipped = 0, p.front().data.bound.clear();
  note.clear();
  CHECK(chart::chart_level_steps(c.D, c.refs, c.jobs, c.profiles, MeasureOptions{}, ref, &note));
  CHECK(ref.horizontal_bars.contrast == doctest::Approx(-0.9).epsilon(0.05));
}

// three_bars(-0.95, ...) with each bar's edges undershooting by 0.12 of
// the ground over a quarter bar inside (a resampling filter's or a sharpening's ringing)
// and the bins that fall below zero clipped there: at 0, a bound
// (ProfileData::bound -1, the true level at most that). With `saturate`,
// the ground beside the triplet is clipped at 0.9 too (bound +1).
ProfileData ringing_clipped_bars(unsigned seed, bool saturate) {
  ProfileData d = three_bars(-0.95, 1.0, 0.1, 0.002, seed);
  d.bound.assign(d.bin_count, 0);
  for (int b = 0; b < d.bin_count; ++b) {
    const double u = d.bin_center_mm(b);
    for (int k = -1; k <= 1; ++k)
      for (const double edge : {(2 * k - 0.5), (2 * k + 0.5)}) {
        const double inside = std::abs(u - edge) < 0.25 && std::abs(u - 2 * k) < 0.5;
        if (inside) d.value[b] -= 0.12;
      }
    if (d.value[b] <= 0) d.value[b] = 0, d.bound[b] = -1;
    if (saturate && std::abs(u) > 3 && d.value[b] > 0.9) d.value[b] = 0.9, d.bound[b] = 1;
  }
  return d;
}

TEST_CASE("chart level step: where every coarse pattern clips at black only, the clipped bins are fitted as bounds") {
  CoarsePatterns c = coarse_patterns(2, -1, 0.5, [](int k) { return ringing_clipped_bars(30 + k, false); });
  for (auto& p : c.profiles) {
    int bound = 0;
    for (const signed char b : p.front().data.bound) bound += b != 0;
    REQUIRE(bound > 0);
    p.front().pixels_clipped = 300;  // more than 2 % of its 1000
  }
  ReferenceResult ref;
  std::string note;
  REQUIRE(chart::chart_level_steps(c.D, c.refs, c.jobs, c.profiles, MeasureOptions{}, ref, &note));
  CHECK(ref.horizontal_bars.contrast == doctest::Approx(-0.95).epsilon(0.04));
  CHECK(note.find("clipped at black") != std::string::npos);
  // Never for a lone pattern: three strokes drawn in clipped black look like one.
  c.D.single_pattern = true;
  CHECK_FALSE(chart::chart_level_steps(c.D, c.refs, c.jobs, c.profiles, MeasureOptions{}, ref, &note));
  c.D.single_pattern = false;
  // One unclipped pattern is preferred: the clipped ones are left out.
  CoarsePatterns mixed = coarse_patterns(3, -1, 0.5, [](int k) {
    return k == 2 ? three_bars(-0.90, 1.0, 0.1, 0.002, 7) : ringing_clipped_bars(30 + k, false);
  });
  for (int k = 0; k < 2; ++k) mixed.profiles[k].front().pixels_clipped = 300;
  note.clear();
  REQUIRE(chart::chart_level_steps(mixed.D, mixed.refs, mixed.jobs, mixed.profiles, MeasureOptions{}, ref, &note));
  CHECK(ref.horizontal_bars.contrast == doctest::Approx(-0.90).epsilon(0.01));
  CHECK(note.find("clipped at black") == std::string::npos);
  // Clipped at saturation as well, the ground is unknown: refused.
  CoarsePatterns bright = coarse_patterns(2, -1, 0.5, [](int k) { return ringing_clipped_bars(30 + k, true); });
  for (auto& p : bright.profiles) p.front().pixels_clipped = 300;
  note.clear();
  CHECK_FALSE(chart::chart_level_steps(bright.D, bright.refs, bright.jobs, bright.profiles, MeasureOptions{}, ref, &note));
  CHECK(note.find("clipped") != std::string::npos);
  // Clipped at black on the light side (the ground between the bars at
  // zero), the light level is unknown too: refused.
  CoarsePatterns dark_ground = coarse_patterns(2, -1, 0.5, [](int k) {
    ProfileData d = three_bars(-0.95, 1.0, 0.1, 0.002, 30 + k);
    d.bound.assign(d.bin_count, 0);
    for (int b = 0; b < d.bin_count; ++b)
      if (d.ideal_at(d.bin_center_mm(b)) == 0 && std::abs(d.bin_center_mm(b)) < 2) d.value[b] = 0, d.bound[b] = -1;
    return d;
  });
  for (auto& p : dark_ground.profiles) p.front().pixels_clipped = 300;
  CHECK_FALSE(chart::chart_level_steps(dark_ground.D, dark_ground.refs, dark_ground.jobs, dark_ground.profiles,
                                       MeasureOptions{}, ref, &note));
}

TEST_CASE("chart level step: a clipped bin is no plateau") {
  // One bar's ink bins clipped, reading 0.5 (only a bound): the step comes
  // from the other two bars, as if that bar were not there.
  ProfileData d = three_bars(-0.8, 1.0, 0.1, 0.002, 3);
  d.bound.assign(d.bin_count, 0);
  for (int b = 0; b < d.bin_count; ++b)
    if (std::abs(d.bin_center_mm(b) + 2) < 0.4) d.value[b] = 0.5, d.bound[b] = -1;
  const auto s = chart::plateau_level_step(d, 1.0);
  REQUIRE(s);
  CHECK(s->contrast == doctest::Approx(-0.8).epsilon(0.01));
}

TEST_CASE("chart level step: bars 0.07 of a bar off their placement still give the true step") {
  // The correlation centring leaves a pattern a tenth of a bar or so off;
  // with the PSF shape free, a fit that holds the bars where they were
  // placed read that as heavier tails and a deeper step (the generated
  // chart's: c -0.966 for -0.941). Three coarse patterns of each
  // orientation, 1 mm bars (0.5 lp/mm), each off by 0.07 mm.
  const CoarsePatterns c = coarse_patterns(
      6, -1, 0.5, [](int k) { return three_bars(-0.94, 1.0, 0.3, 0.001, 10 + k, k < 3 ? 0.07 : -0.07); });
  ReferenceResult ref;
  std::string note;
  REQUIRE(chart::chart_level_steps(c.D, c.refs, c.jobs, c.profiles, MeasureOptions{}, ref, &note));
  for (const LevelStep& s : {ref.horizontal_bars, ref.vertical_bars}) {
    CHECK(s.contrast == doctest::Approx(-0.94).epsilon(0.003));
    CHECK(std::abs(s.contrast + 0.94) < 3 * s.contrast_sigma + 1e-3);
  }
}

TEST_CASE("chart level step: coarse patterns that disagree widen the step's sigma to their scatter") {
  // Three patterns an orientation whose steps differ by 0.04 (a print's
  // uneven ink, a misfit each fit claims to know to +-0.001): the median
  // stands, its sigma is their sample sd.
  const double steps[3] = {-0.90, -0.94, -0.98};
  const CoarsePatterns c =
      coarse_patterns(6, -1, 0.5, [&](int k) { return three_bars(steps[k / 2], 1.0, 0.3, 0.001, 20 + k); });
  ReferenceResult ref;
  std::string note;
  REQUIRE(chart::chart_level_steps(c.D, c.refs, c.jobs, c.profiles, MeasureOptions{}, ref, &note));
  for (const LevelStep& s : {ref.horizontal_bars, ref.vertical_bars}) {
    CHECK(s.contrast == doctest::Approx(-0.94).epsilon(0.003));
    CHECK(s.contrast_sigma == doctest::Approx(0.04).epsilon(0.05));
  }
}

TEST_CASE("chart level step: a shift the fit ends on the range's edge does not place the bars") {
  // Ceres' covariance is blind to the bound: a shift stopped at a quarter
  // bar still reads a small sigma. Bars 0.07 bar off are placed there;
  // bars half a bar off stop at the edge and are not (chart_level_steps
  // then fits them where the centring put them, as refine_shift_by_fit
  // leaves them).
  ProfileFitOptions fo;
  fo.fit_contrast = true;
  const ProfileFitOptions free_fo = chart::with_free_shift(fo, 1.0);
  CHECK(free_fo.fit_shift);
  CHECK(free_fo.max_shift_mm == doctest::Approx(0.25));
  const ProfileFit near = fit_profile(three_bars(-0.94, 1.0, 0.3, 0.001, 40, 0.07), free_fo);
  CHECK(chart::shift_placed(near, 1.0));
  CHECK(near.shift_mm == doctest::Approx(0.07).epsilon(0.05));
  const ProfileFit far = fit_profile(three_bars(-0.94, 1.0, 0.3, 0.001, 41, 0.5), free_fo);
  REQUIRE(far.usable);
  CHECK(std::abs(far.shift_mm) > 0.99 * 0.25);
  CHECK_FALSE(chart::shift_placed(far, 1.0));
}
