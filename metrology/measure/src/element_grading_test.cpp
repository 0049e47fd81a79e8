#include "tactres/measure/element_grading.h"

#include <cmath>
#include <numbers>
#include <tuple>
#include <vector>

#include <doctest/doctest.h>
#include <opencv2/imgproc.hpp>

#include "tactres/camera/plane_map.h"
#include "test_triplet.h"

using namespace tactres;

namespace {

// One orientation of group 2, elements 1..6, with the given m (sigma 0.02).
Measurement row_of(const std::vector<double>& m) {
  Measurement M;
  for (size_t i = 0; i < m.size(); ++i) {
    const int element = static_cast<int>(i) + 1;
    ElementResult r = ElementResult::of(2, element, BarOrientation::vertical_bars, 4.0 * std::exp2(i / 6.0), 5.0);
    r.status = ElementStatus::ok;
    r.m = m[i];
    r.m_sigma = 0.02;
    M.elements.push_back(r);
  }
  return M;
}

}  // namespace

TEST_CASE("damaged: an element without bars before two finer resolved ones is left out of the limit") {
  Criterion c;
  Measurement M = row_of({0.8, 0.02, 0.7, 0.6, 0.4, 0.05});
  grade_damaged(M, c);
  CHECK(M.elements[1].status == ElementStatus::damaged);
  CHECK(M.elements[1].note.find("G2E3 and G2E4") != std::string::npos);
  // The finest unresolved one has no finer neighbours: the optics.
  CHECK(M.elements[5].status == ElementStatus::ok);
  decide_limits(M, c, {}, true);
  CHECK_FALSE(M.elements[1].resolved);
  const Limit& optical = M.vertical_parts.optical;  // (no CNR here, so no detectability limit)
  CHECK(optical.group == 2);
  CHECK(optical.element == 5);
  REQUIRE(optical.bridged.size() == 1);
  CHECK(optical.bridged[0].element == 2);
}

TEST_CASE("damaged: not when a finer neighbour is unresolved or within the errors") {
  Criterion c;
  // E2 fails, E3 resolved, E4 not: an ordinary limit at E1.
  Measurement a = row_of({0.5, 0.05, 0.3, 0.05, 0.02, 0.01});
  grade_damaged(a, c);
  for (const ElementResult& e : a.elements) CHECK(e.status == ElementStatus::ok);
  // E2 just below the threshold, its finer neighbours just above it: no
  // significant rise with frequency, so no defect is claimed.
  Measurement b = row_of({0.5, 0.09, 0.11, 0.12, 0.05, 0.02});
  grade_damaged(b, c);
  CHECK(b.elements[1].status == ElementStatus::ok);
  // An aliased element (no bars at all) before two resolved ones is damaged.
  Measurement d = row_of({0.8, 0.0, 0.7, 0.6, 0.4, 0.05});
  d.elements[1].status = ElementStatus::aliased;
  grade_damaged(d, c);
  CHECK(d.elements[1].status == ElementStatus::damaged);
}

TEST_CASE("damaged: across one missing element of the series, not across two missing in a row") {
  Criterion c;
  // E2 shows no bars; E3 was never found (cut away by the field's edge):
  // E4 and E5, one and two steps past the gap, show the bars.
  Measurement one_gap = row_of({0.8, 0.02, 0.7, 0.6, 0.4, 0.05});
  one_gap.elements.erase(one_gap.elements.begin() + 2);
  grade_damaged(one_gap, c);
  CHECK(one_gap.elements[1].status == ElementStatus::damaged);
  CHECK(one_gap.elements[1].note.find("G2E4 and G2E5") != std::string::npos);
  // E3 and E4 both missing: E5 is three steps on, too far to speak for E2.
  Measurement two_gap = row_of({0.8, 0.02, 0.7, 0.6, 0.5, 0.4});
  two_gap.elements.erase(two_gap.elements.begin() + 2, two_gap.elements.begin() + 4);
  grade_damaged(two_gap, c);
  CHECK(two_gap.elements[1].status == ElementStatus::ok);
  // E3 and E4 found but not measured (fit_failed: cut by the field's edge),
  // E5 not found: their indices are known, and one element is missing.
  Measurement unmeasured = row_of({0.8, 0.02, 0.7, 0.6, 0.5, 0.4, 0.35});
  unmeasured.elements.erase(unmeasured.elements.begin() + 4);
  for (const size_t k : {2, 3}) unmeasured.elements[k].status = ElementStatus::fit_failed;
  grade_damaged(unmeasured, c);
  CHECK(unmeasured.elements[1].status == ElementStatus::damaged);
}

namespace {

// Group 2's E1-E6 with the given m, E1 and E3 without bars (low_signal)
// and E2 not measured (fit_failed): the field's rim over E1-E3.
Measurement rim_row(const std::vector<double>& m) {
  Measurement M = row_of(m);
  M.elements[0].status = M.elements[2].status = ElementStatus::low_signal;
  M.elements[1].status = ElementStatus::fit_failed;
  return M;
}

}  // namespace

TEST_CASE("damaged: a coarser element looks past finer ones judged damaged") {
  Criterion c;
  // The field's rim over E1-E3 (a blurred copy of dev_01: G5E3-E5 H): E1
  // and E3 show no bars, E2 is not measured, E4 and E5 show them. E3 is
  // damaged by E4 and E5, and so, looking past E2 and E3, is E1.
  Measurement M = rim_row({0.0, 0.5, 0.0, 0.55, 0.55, 0.3});
  grade_damaged(M, c);
  CHECK(M.elements[2].status == ElementStatus::damaged);
  CHECK(M.elements[0].status == ElementStatus::damaged);
  CHECK(M.elements[0].note.find("G2E4 and G2E5") != std::string::npos);
  decide_limits(M, c, {}, true);
  const Limit& optical = M.vertical_parts.optical;
  CHECK(optical.group == 2);
  CHECK(optical.element == 6);
  // Not when the element past the rim shows no bars either (E4 m 0.05):
  // E3 is not judged damaged, so E1 looks at E3 and E4 and stays ok.
  Measurement N = rim_row({0.0, 0.5, 0.0, 0.05, 0.55, 0.05});
  grade_damaged(N, c);
  CHECK(N.elements[2].status == ElementStatus::low_signal);
  CHECK(N.elements[0].status == ElementStatus::low_signal);
  // A longer run without bars is no local defect: E2-E4 show none before
  // E5 and E6. E4 and E3 (past E4) are damaged; E2 would pass over two.
  Measurement R = row_of({0.8, 0.0, 0.0, 0.0, 0.55, 0.55});
  grade_damaged(R, c);
  CHECK(R.elements[3].status == ElementStatus::damaged);
  CHECK(R.elements[2].status == ElementStatus::damaged);
  CHECK(R.elements[1].status == ElementStatus::ok);
  decide_limits(R, c, {}, true);
  CHECK(R.vertical_parts.optical.element == 1);
}

namespace {

// A vertical-bar triplet (bar width 0.1 mm, at 40 px/mm 4 px per bar)
// blurred by a Gaussian of `blur_px`, ground `ground` x (1 - 0.8 S), with
// the ground above the clip level 1 where `ground` > 1; its strip's profile
// sampled with clip level 1. `period_scale` != 1 draws the bars at another
// period than the layout's.
constexpr double kBarMm = 0.1;

// The bars' coverage (0 or 1) of a 200 x 200 px frame about the triplet.
cv::Mat triplet_ink(double period_scale, double px_per_mm) {
  cv::Mat ink(200, 200, CV_32F, cv::Scalar(0));
  for (int y = 0; y < ink.rows; ++y)
    for (int x = 0; x < ink.cols; ++x) {
      const double u = (x + 0.5 - 100) / px_per_mm, v = (y + 0.5 - 100) / px_per_mm;
      for (int k = -1; k <= 1; ++k)
        if (std::abs(u - 2 * k * kBarMm * period_scale) < 0.5 * kBarMm && std::abs(v) < 2.5 * kBarMm)
          ink.at<float>(y, x) = 1;
    }
  return ink;
}

// The layout triplet's strip profile in `lum`, with clip level 1.
SampledProfile triplet_profile(const cv::Mat& lum, double px_per_mm) {
  const test::TripletLayout triplet = test::vertical_triplet(kBarMm);
  const IndexedArtwork artwork(triplet.shapes);
  const PatternFrame frame({100, 100}, {1, 0}, px_per_mm);
  const ProfileSamplingOptions so;
  return sample_strip(lum, frame, artwork, element_strip(triplet.element, so), so, 1.0);
}

SampledProfile clipped_triplet(double ground, double blur_px, double period_scale = 1.0, double px_per_mm = 40) {
  cv::Mat ink = triplet_ink(period_scale, px_per_mm);
  cv::GaussianBlur(ink, ink, {0, 0}, blur_px);
  cv::Mat lum = ground * (1 - 0.8 * ink);
  cv::min(lum, 1.0, lum);
  return triplet_profile(lum, px_per_mm);
}

ElementResult graded(const SampledProfile& sp, double px_per_bar, bool read_gap_dips = false) {
  ElementResult r = ElementResult::of(2, 1, BarOrientation::vertical_bars, 5.0, px_per_bar);
  ProfileFitOptions fo;
  fo.contrast = -0.8;
  std::pair<double, double> warm{0, 0};
  grade_element(r, sp, fo, 0.0, MeasureOptions{}, warm, {}, false, read_gap_dips);
  return r;
}

}  // namespace

TEST_CASE("clipped: a ground above saturation is fitted as bounds, m as if nothing clipped") {
  // Ground at 1.25 clipped to 1: the margins and gap crests are bounds.
  const SampledProfile sp = clipped_triplet(1.25, 1.2);
  REQUIRE(sp.in_view);
  REQUIRE(sp.pixels_clipped > sp.pixels_used / 50);
  REQUIRE(sp.pixels_clipped < sp.pixels_used / 2);
  const ElementResult r = graded(sp, 4.0);
  REQUIRE(r.status == ElementStatus::ok);
  CHECK(r.note.find("clipped") != std::string::npos);
  const ElementResult unclipped = graded(clipped_triplet(0.95, 1.2), 4.0);
  REQUIRE(unclipped.status == ElementStatus::ok);
  CHECK(std::abs(r.m - unclipped.m) < 2 * r.m_sigma + 0.01);
}

TEST_CASE("clipped: a clipped profile the model misses is clipped, and so is a strip mostly clipped") {
  // The bars drawn at 0.6x the layout's period (graded as if at 2.5 px per
  // bar), so the fit misses them; with clipping this cannot be told from a
  // distorted clipped profile.
  constexpr double scale = 0.6;
  const SampledProfile sp = clipped_triplet(1.25, 0.6, scale);
  REQUIRE(sp.pixels_clipped > sp.pixels_used / 50);
  const ElementResult r = graded(sp, 2.5);
  CHECK(r.status == ElementStatus::clipped);
  CHECK(r.note.find("clipped") != std::string::npos);
  // Without clipping the same bars are not called measured either.
  CHECK(graded(clipped_triplet(0.95, 0.6, scale), 2.5).status != ElementStatus::ok);
  // A ground far above the clip level: more than half of the strip.
  const SampledProfile most = clipped_triplet(6.0, 1.2);
  REQUIRE(most.pixels_clipped > most.pixels_used / 2);
  CHECK(graded(most, 4.0).status == ElementStatus::clipped);
}

// A box-shaped vertical-bar triplet as a profile (bars 0.1 mm on 0.01 mm
// bins, 2.5 px per bar): bars at 0.05, gaps at `gap`, a ground of 0.9,
// clipped at saturation (bounds) beyond 0.42 mm and, with `ground_clipped`,
// also beside the triplet; all times `scale`. Sharp bars between gaps far
// under the ground: no blur of the model makes that (a resampled
// photograph's halos did, dev_14), so its fit misses the data.
SampledProfile halo_triplet(double scale, double gap = 0.15, bool ground_clipped = false) {
  SampledProfile sp;
  ProfileData& d = sp.data;
  d.bin_mm = 0.01;
  d.bin_count = 100;
  d.u0_mm = -0.5;
  d.fit_begin = 0;
  d.fit_end = d.bin_count;
  for (int i = 0; i < 3; ++i) d.ideal.push_back({(i - 1) * 0.2 - 0.05, (i - 1) * 0.2 + 0.05, 1.0});
  for (int b = 0; b < d.bin_count; ++b) {
    const double u = d.bin_center_mm(b);
    double v = 0.9;
    signed char bound = std::abs(u) > 0.42 || ground_clipped ? 1 : 0;
    if (std::abs(u) < 0.25) v = gap, bound = 0;
    for (int i = 0; i < 3; ++i)
      if (std::abs(u - (i - 1) * 0.2) < 0.05) v = 0.05;
    d.value.push_back(scale * v);
    d.u_mean_mm.push_back(u);
    d.sigma.push_back(scale * 0.005);
    d.count.push_back(4);
    d.bound.push_back(bound);
  }
  sp.in_view = true;
  sp.px_per_mm_across = sp.px_per_mm_along = 25;
  sp.pixels_used = 400;
  sp.pixels_clipped = ground_clipped ? 100 : 60;
  return sp;
}

TEST_CASE("clipped: a misfit with three clear bars is read from its dips, chart photographs only") {
  const SampledProfile sp = halo_triplet(1.0);
  const ElementResult layout_mode = graded(sp, 2.5);
  INFO(layout_mode.note);
  REQUIRE(layout_mode.status == ElementStatus::clipped);
  const ElementResult r = graded(sp, 2.5, true);
  INFO(r.note);
  REQUIRE(r.status == ElementStatus::ok);
  CHECK(r.m_from_dips);
  CHECK(r.beta == 0);
  CHECK(r.note.find("model-free") != std::string::npos);
  // Dips of 0.10 against a step of 0.8 of the ground, 0.9 beside the
  // triplet (or the fit's B0 if higher): m = pi/4 0.10 / 0.72 at most.
  const double m_ground = std::numbers::pi / 4 * 0.10 / (0.8 * 0.9);
  CHECK(r.m <= m_ground + 1e-9);
  CHECK(r.m > 0.8 * m_ground);
  // The level step scales with the light: half the light, the same m.
  const ElementResult dim = graded(halo_triplet(0.5), 2.5, true);
  REQUIRE(dim.status == ElementStatus::ok);
  CHECK(dim.m == doctest::Approx(r.m).epsilon(0.02));
  // Shallow dips are read too, and are unresolved (they end the chain).
  const ElementResult shallow = graded(halo_triplet(1.0, 0.09), 2.5, true);
  INFO(shallow.note);
  CHECK(shallow.status == ElementStatus::ok);
  CHECK(shallow.m < 0.1);
  // A ground clipped beside the triplet leaves the step unknown: clipped.
  CHECK(graded(halo_triplet(1.0, 0.15, true), 2.5, true).status == ElementStatus::clipped);
  // Bars at another period than the layout's are not read from dips: no
  // clear dips where the layout puts the gaps.
  const SampledProfile other = clipped_triplet(1.1, 0.6, 0.6);
  REQUIRE(other.pixels_clipped > other.pixels_used / 50);
  REQUIRE(other.pixels_clipped < other.pixels_used / 2);
  const ElementResult o = graded(other, 2.5, true);
  CHECK(o.status != ElementStatus::ok);
  CHECK_FALSE(o.m_from_dips);
}

TEST_CASE("under the sampling floor: a chart photograph's element counts only where its three bars show") {
  // 1.2 px per bar (12 px/mm), under the 1.25 floor.
  const SampledProfile sharp = clipped_triplet(0.9, 0.6, 1.0, 12);
  REQUIRE(sharp.pixels_clipped == 0);
  CHECK(graded(sharp, 1.2).status == ElementStatus::below_sampling_limit);  // layout mode: the floor
  const ElementResult seen = graded(sharp, 1.2, true);
  INFO(seen.note);
  CHECK(seen.status == ElementStatus::ok);
  CHECK(seen.note.find("kept because its data show all three bars") != std::string::npos);
  // Blurred to a faint ripple: not called anything, below the floor.
  const ElementResult faint = graded(clipped_triplet(0.9, 1.5, 1.0, 12), 1.2, true);
  INFO(faint.note);
  CHECK(faint.status == ElementStatus::below_sampling_limit);
  CHECK(faint.m == 0);
  CHECK(faint.note.find("under the 1.25 floor") != std::string::npos);
  CHECK(faint.note.find("kept") == std::string::npos);
  // A fit dropped under the floor does not warm-start the next one; a kept
  // one does.
  ElementResult r = ElementResult::of(2, 1, BarOrientation::vertical_bars, 5.0, 1.2);
  ProfileFitOptions fo;
  fo.contrast = -0.8;
  std::pair<double, double> warm{3.0, 2.5};
  grade_element(r, clipped_triplet(0.9, 1.5, 1.0, 12), fo, 0.0, MeasureOptions{}, warm, {}, false, true);
  REQUIRE(r.status == ElementStatus::below_sampling_limit);
  CHECK(warm == std::pair<double, double>{3.0, 2.5});
  r = ElementResult::of(2, 1, BarOrientation::vertical_bars, 5.0, 1.2);
  grade_element(r, sharp, fo, 0.0, MeasureOptions{}, warm, {}, false, true);
  REQUIRE(r.status == ElementStatus::ok);
  CHECK(warm != std::pair<double, double>{3.0, 2.5});
  // At or under 1 px per bar nothing is fitted, chart photograph or not.
  CHECK(graded(sharp, 1.0, true).status == ElementStatus::below_sampling_limit);
}

TEST_CASE("a flat gap: an ok element whose triplet shows two bars is never resolved, and ends the chain") {
  Criterion c;
  Measurement M = row_of({0.8, 0.6, 0.5, 0.3, 0.2, 0.05});
  M.elements[3].gap_flat = true;  // m 0.3, but one gap does not dip
  grade_damaged(M, c);
  // Its finer neighbours are below m 0.3: no local defect, the optics.
  CHECK(M.elements[3].status == ElementStatus::ok);
  decide_limits(M, c, {}, true);
  CHECK_FALSE(M.elements[3].resolved);
  CHECK(M.elements[4].resolved);  // resolved on its own, beyond the chain
  const Limit& optical = M.vertical_parts.optical;
  CHECK(optical.element == 3);
  CHECK(optical.bridged.empty());
  // Without the flag the same m reach E5.
  Measurement plain = row_of({0.8, 0.6, 0.5, 0.3, 0.2, 0.05});
  decide_limits(plain, c, {}, true);
  CHECK(plain.vertical_parts.optical.element == 5);
}

TEST_CASE("shown by its dips: a poorly fitting element whose gaps read m significantly is resolved") {
  Criterion c;
  DetectabilityCriterion rose;
  // E4's fit reads m 0.16 +- 0.10 (a poor fit's widened sigma), not 2 sigma
  // above zero; its dips read m 0.13 +- 0.04 model-free.
  const auto row = [](double dips_m, double dips_m_sigma) {
    Measurement M = row_of({0.8, 0.6, 0.5, 0.16, 0.05, 0.02});
    for (ElementResult& e : M.elements) e.cnr = 50 * e.m, e.cnr_sigma = 50 * e.m_sigma;
    ElementResult& e4 = M.elements[3];
    e4.m_sigma = 0.10;
    e4.cnr_sigma = 50 * e4.m_sigma;
    e4.dips_m = dips_m;
    e4.dips_m_sigma = dips_m_sigma;
    return M;
  };
  Measurement M = row(0.13, 0.04);
  decide_limits(M, c, rose, true);
  const ElementResult& e4 = M.elements[3];
  INFO(e4.note);
  CHECK(e4.resolved);
  CHECK(e4.detectable);  // CNR 8 >= k 5, its presence shown by the dips
  CHECK(e4.note.find("read model-free from its gaps' dips, m 0.130 +- 0.040, it is: resolved") != std::string::npos);
  CHECK(M.vertical_parts.optical.element == 4);
  CHECK(M.vertical_parts.detectability.element == 4);
  // The dips' own m below the threshold, or not 2 sigma above zero: the
  // fit's sigma decides, and E4 ends the chain at E3.
  for (const auto& [dm, ds] : {std::pair{0.08, 0.02}, std::pair{0.13, 0.07}, std::pair{0.13, 0.0}}) {
    Measurement N = row(dm, ds);
    decide_limits(N, c, rose, true);
    CAPTURE(dm);
    CAPTURE(ds);
    CHECK_FALSE(N.elements[3].resolved);
    CHECK(N.elements[3].note.find("not 2 sigma above 0") != std::string::npos);
    CHECK(N.vertical_parts.optical.element == 3);
  }
}

TEST_CASE("shown by its dips: a triplet the model misses is resolved by its gaps, in chart mode only") {
  // Bars of unequal depth (15 % deeper per bar, left to right), blurred by
  // 0.75 px at 1.65 px per bar (16.5 px/mm), with noise 0.01 on a ground
  // of 0.6: the model, one depth and a smooth LSF, misses the profile
  // (reduced chi^2 over 100), the poor fit widens m_sigma past m / 2, and
  // the gaps still dip.
  constexpr double kPxPerMm = 16.5;
  cv::Mat ink = triplet_ink(1.0, kPxPerMm);
  cv::GaussianBlur(ink, ink, {0, 0}, 0.75);
  cv::Mat lum(ink.size(), CV_32F);
  const double bar_pitch_px = 2 * kBarMm * kPxPerMm;
  for (int y = 0; y < lum.rows; ++y)
    for (int x = 0; x < lum.cols; ++x)
      lum.at<float>(y, x) =
          static_cast<float>(0.6 * (1 - 0.8 * (1 + 0.15 * (x - 100) / bar_pitch_px) * ink.at<float>(y, x)));
  cv::Mat noise(lum.size(), CV_32F);
  cv::RNG rng(7);
  rng.fill(noise, cv::RNG::NORMAL, 0, 0.01);
  lum += noise;
  const SampledProfile unequal = triplet_profile(lum, kPxPerMm);
  REQUIRE(unequal.pixels_clipped == 0);
  const ElementResult r = graded(unequal, 0.1 * kPxPerMm, true);
  INFO(r.note);
  CAPTURE(r.m);
  CAPTURE(r.m_sigma);
  CAPTURE(r.chi2_reduced);
  CAPTURE(r.dips_m);
  CAPTURE(r.dips_m_sigma);
  REQUIRE(r.status == ElementStatus::ok);
  CHECK(r.chi2_reduced > 5);  // the model misses the profile
  REQUIRE(r.m >= 0.1);
  REQUIRE(r.m - 2 * r.m_sigma <= 0);  // the fit alone would not resolve it
  REQUIRE(r.dips_m_sigma > 0);
  CHECK(r.dips_m - 2 * r.dips_m_sigma > 0);
  Measurement M;
  M.elements.push_back(r);
  decide_limits(M, Criterion{}, {}, true);
  CHECK(M.elements[0].resolved);
  CHECK(M.elements[0].note.find("read model-free from its gaps' dips") != std::string::npos);
  // Layout mode reads no dips: the fit's sigma decides, and it does not resolve.
  const ElementResult layout = graded(unequal, 0.1 * kPxPerMm);
  CHECK(layout.dips_m_sigma == 0);
  Measurement L;
  L.elements.push_back(layout);
  decide_limits(L, Criterion{}, {}, false);
  CHECK_FALSE(L.elements[0].resolved);
}

TEST_CASE("elements not found: a chart photograph's chain lists the ones it passes, a layout has none missing") {
  Criterion c;
  // G2E3 and G2E4 were never found (cut off): only E1, E2, E5, E6 measured.
  Measurement M = row_of({0.8, 0.7, 0.6, 0.5, 0.4, 0.05});
  M.elements.erase(M.elements.begin() + 2, M.elements.begin() + 4);
  decide_limits(M, c, {}, true);
  const Limit& optical = M.vertical_parts.optical;
  CHECK(optical.group == 2);
  CHECK(optical.element == 5);
  REQUIRE(optical.bridged.size() == 2);
  CHECK(optical.bridged[0].element == 3);
  CHECK(optical.bridged[1].element == 4);
  // Across a group boundary and with relative (negative) groups.
  Measurement R;
  for (const auto& [group, element, m] : std::vector<std::tuple<int, int, double>>{{-1, 5, 0.9}, {0, 2, 0.8}, {0, 3, 0.01}}) {
    ElementResult r = ElementResult::of(group, element, BarOrientation::horizontal_bars,
                                        std::exp2(group + (element - 1) / 6.0), 5.0);
    r.status = ElementStatus::ok;
    r.m = m;
    r.m_sigma = 0.02;
    R.elements.push_back(r);
  }
  decide_limits(R, c, {}, true);
  const Limit& h = R.horizontal_parts.optical;
  CHECK(h.element == 2);
  REQUIRE(h.bridged.size() == 2);
  CHECK((h.bridged[0].group == -1 && h.bridged[0].element == 6));
  CHECK((h.bridged[1].group == 0 && h.bridged[1].element == 1));
  // A layout lists what its target holds: nothing is missing from it.
  Measurement L = row_of({0.8, 0.7, 0.6, 0.5, 0.4, 0.05});
  L.elements.erase(L.elements.begin() + 2, L.elements.begin() + 4);
  decide_limits(L, c, {}, false);
  CHECK(L.vertical_parts.optical.element == 5);
  CHECK(L.vertical_parts.optical.bridged.empty());
}

TEST_CASE("the LSF shape on its bound: an ok element says m holds for the bounded family, where that moves m") {
  // Half the light in a core of 1.2 px, half in a halo of 12 px (4 px
  // per bar): tails heavier than any beta >= 1 gives.
  const cv::Mat ink = triplet_ink(1.0, 40);
  cv::Mat core, halo;
  cv::GaussianBlur(ink, core, {0, 0}, 1.2);
  cv::GaussianBlur(ink, halo, {0, 0}, 12.0);
  const ElementResult haloed = graded(triplet_profile(0.9 * (1 - 0.8 * (0.5 * core + 0.5 * halo)), 40), 4.0);
  REQUIRE(haloed.status == ElementStatus::ok);
  CAPTURE(haloed.note);
  CHECK(haloed.beta == doctest::Approx(1.0));
  CHECK(haloed.note.find("the LSF shape is held at its bound beta = 1 (the data favour beta below it") !=
        std::string::npos);
  // A Gaussian LSF: beta inside its range, no such note.
  const ElementResult gaussian = graded(clipped_triplet(0.9, 1.5), 4.0);
  REQUIRE(gaussian.status == ElementStatus::ok);
  CHECK(gaussian.note.find("bound") == std::string::npos);
}

TEST_CASE("nothing resolved: the problem names the clipping where no element was fitted, else the focus") {
  Measurement M = row_of({0.02, 0.01});
  for (ElementResult& e : M.elements) e.status = ElementStatus::clipped;
  const std::string clipped = unresolved_chart_problem(M.elements);
  CHECK(clipped.find("no element on the chart could be measured") != std::string::npos);
  CHECK(clipped.find("2 of the 2 elements in view") != std::string::npos);
  CHECK(clipped.find("clip") != std::string::npos);
  // One element fitted and unresolved: the chart was measured, and is blurred.
  M.elements[0].status = ElementStatus::ok;
  const std::string blurred = unresolved_chart_problem(M.elements);
  CHECK(blurred.find("nothing on the chart is resolved") != std::string::npos);
  CHECK(blurred.find("focus") != std::string::npos);
}

namespace {

// halo_triplet's sharp bars between gaps far under the ground, nothing
// clipped (no blur of the model makes that profile), filled in every
// `every`-th bin only.
SampledProfile unclipped_halo(int every) {
  SampledProfile sp = halo_triplet(1.0);
  sp.data.bound.clear();
  sp.pixels_clipped = 0;
  for (int b = 0; b < sp.data.bin_count; ++b)
    if (b % every) sp.data.count[b] = 0, sp.data.value[b] = std::nan("");
  return sp;
}

// Graded `layout_status` in layout mode and, in a chart photograph, ok
// with m read from its dips, its note saying `why` the fit alone did not
// do, and that both gaps dip.
ElementResult check_read_from_dips(const SampledProfile& sp, double px_per_bar, ElementStatus layout_status,
                                   const std::string& why) {
  const ElementResult layout_mode = graded(sp, px_per_bar);
  INFO(layout_mode.note);
  CHECK(layout_mode.status == layout_status);
  const ElementResult r = graded(sp, px_per_bar, true);
  INFO(r.note);
  CHECK(r.status == ElementStatus::ok);
  CHECK(r.m_from_dips);
  CHECK(r.note.find(why) != std::string::npos);
  CHECK(r.note.find("both gaps dip") != std::string::npos);
  return r;
}

}  // namespace

TEST_CASE("misfit: a triplet the model misses whose gaps dip is read from its dips unclipped too, chart photographs only") {
  const ElementResult r =
      check_read_from_dips(unclipped_halo(1), 2.5, ElementStatus::aliased, "the model misses the data");
  const double m_ground = std::numbers::pi / 4 * 0.10 / (0.8 * 0.9);
  CHECK(r.m <= m_ground + 1e-9);
  CHECK(r.m > 0.8 * m_ground);
  // Bars at another period than the layout's show no dips where the
  // layout puts the gaps: still no bars of the layout's.
  const SampledProfile other = clipped_triplet(0.95, 0.6, 0.6);
  REQUIRE(other.pixels_clipped == 0);
  const ElementResult o = graded(other, 2.5, true);
  INFO(o.note);
  CHECK(o.status != ElementStatus::ok);
  CHECK_FALSE(o.m_from_dips);
}

TEST_CASE("misfit: a fit widened past max_m_sigma whose gaps dip is read from its dips, chart photographs only") {
  // The same profile filled in every fourth bin only (a strip along the
  // pixel grid fills one bin a pixel: dev_14 resized by 1.25, G7E1 H, 16
  // bins), at 3.5 px per bar (past the aliasing test): the misfit widens
  // m_sigma beyond 0.25.
  const ElementResult r =
      check_read_from_dips(unclipped_halo(4), 3.5, ElementStatus::low_signal, "the fit cannot pin m down");
  CHECK(r.m - 2 * r.m_sigma > 0);
}
