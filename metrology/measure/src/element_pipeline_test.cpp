#include "tactres/measure/element_pipeline.h"

#include <cmath>

#include <doctest/doctest.h>
#include <opencv2/imgproc.hpp>

#include "test_triplet.h"

using namespace tactres;

namespace {

// A vertical-bar triplet, bar width 0.1 mm at 40 px/mm (4 px per bar),
// ground 0.9 x (1 - 0.8 S), lightly blurred, with Gaussian noise of
// noise_sd, centred at (100, 100).
constexpr double w_mm = 0.1, px_per_mm = 40;
cv::Mat triplet_capture(double noise_sd) {
  constexpr int sub = 8;  // drawn at 8 x 8 samples a pixel, then averaged: area coverage
  cv::Mat fine(200 * sub, 200 * sub, CV_32F, cv::Scalar(0)), ink;
  for (int y = 0; y < fine.rows; ++y)
    for (int x = 0; x < fine.cols; ++x) {
      const double u = ((x + 0.5) / sub - 100) / px_per_mm, v = ((y + 0.5) / sub - 100) / px_per_mm;
      for (int k = -1; k <= 1; ++k)
        if (std::abs(u - 2 * k * w_mm) < 0.5 * w_mm && std::abs(v) < 2.5 * w_mm) fine.at<float>(y, x) = 1;
    }
  cv::resize(fine, ink, {200, 200}, 0, 0, cv::INTER_AREA);
  cv::GaussianBlur(ink, ink, {0, 0}, 1.0);
  cv::Mat lum = 0.9 * (1 - 0.8 * ink), noise(lum.size(), CV_32F);
  cv::RNG rng(7);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, noise_sd);
  return lum + noise;
}

ReferenceResult triplet_reference() {
  ReferenceResult ref;
  ref.usable = true;
  ref.horizontal_bars = ref.vertical_bars = {-0.8, 0.005, 1.0};  // relative to the ground
  return ref;
}

}  // namespace

TEST_CASE("grade_jobs: each placement is graded from scratch, and the better fit wins") {
  const cv::Mat lum = triplet_capture(0.01);

  const test::TripletLayout triplet = test::vertical_triplet(w_mm);
  const ElementLayout& e = triplet.element;
  const IndexedArtwork artwork(triplet.shapes);
  // First a place one bar off (the bars where the gaps are: the fit drives
  // m to 0 and says so), then the right one.
  const PatternFrame off({99.5 + w_mm * px_per_mm, 99.5}, {1, 0}, px_per_mm);
  const PatternFrame right({99.5, 99.5}, {1, 0}, px_per_mm);  // pixel centres at integers
  ElementJob job;
  job.element = ElementResult::of(2, 1, BarOrientation::vertical_bars, e.lp_per_mm, w_mm * px_per_mm);
  job.placements = {{&off, &artwork, element_strip(e, job.sampling)}, {&right, &artwork, element_strip(e, job.sampling)}};
  const std::vector<ElementJob> jobs{job};
  const auto profiles = sample_jobs(lum, jobs, 1.0);

  const ReferenceResult ref = triplet_reference();
  const MeasureOptions mo;
  std::vector<ElementResult> alone, both;
  std::vector<size_t> placement;
  const std::vector<ElementJob> first_only{ElementJob{job.element, {job.placements.front()}, job.sampling, false, {}}};
  grade_jobs(first_only, sample_jobs(lum, first_only, 1.0), {ref, mo}, alone);
  REQUIRE(alone.size() == 1);
  CHECK(alone[0].status != ElementStatus::ok);  // misplaced: reads as no bars
  CHECK(alone[0].note.find("m to 0") != std::string::npos);

  grade_jobs(jobs, profiles, {ref, mo}, both, &placement);
  REQUIRE(both.size() == 1);
  CHECK(placement[0] == 1);
  CHECK(both[0].status == ElementStatus::ok);
  CHECK(both[0].m > 0.5);
  // Nothing of the first placement's grading is left on the winner.
  CHECK(both[0].note.empty());
  CHECK_FALSE(both[0].m_undetermined);
}

TEST_CASE("grade_jobs: no element's noise is taken below the capture's code rounding") {
  // Noise-free, rounded to 8-bit sRGB codes and decoded back, as an
  // untagged 8-bit file would be.
  cv::Mat lum = triplet_capture(0.0);
  const TransferCurve srgb = TransferCurve::srgb();
  for (int y = 0; y < lum.rows; ++y)
    for (int x = 0; x < lum.cols; ++x) {
      float& v = lum.at<float>(y, x);
      v = srgb.to_linear(std::round(srgb.to_code(v) * 255.0f) / 255.0f);
    }
  const test::TripletLayout triplet = test::vertical_triplet(w_mm);
  const IndexedArtwork artwork(triplet.shapes);
  const PatternFrame frame({99.5, 99.5}, {1, 0}, px_per_mm);
  ElementJob job;
  job.element = ElementResult::of(2, 1, BarOrientation::vertical_bars, triplet.element.lp_per_mm, w_mm * px_per_mm);
  job.placements = {{&frame, &artwork, element_strip(triplet.element, job.sampling)}};
  const std::vector<ElementJob> jobs{job};
  const auto profiles = sample_jobs(lum, jobs, 1.0);
  const ReferenceResult ref = triplet_reference();
  const MeasureOptions mo;
  CodeRounding rounding;
  rounding.code_step = 1.0 / 255;
  rounding.curve = srgb;
  std::vector<ElementResult> unfloored, floored;
  grade_jobs(jobs, profiles, {ref, mo}, unfloored);
  grade_jobs(jobs, profiles, {ref, mo, false, false, nullptr, rounding}, floored);
  REQUIRE(unfloored.size() == 1);
  REQUIRE(floored.size() == 1);
  REQUIRE(floored[0].status == ElementStatus::ok);
  const double rounding_sd = rounding.sd_at(floored[0].mean_level);
  // The flat bins of a noise-free frame scatter far less than the rounding
  // (the floor matters), and the floor is what the noise then reads.
  CHECK(unfloored[0].noise_sd < 0.5 * rounding_sd);
  CHECK(floored[0].noise_sd == doctest::Approx(rounding_sd));
  CHECK(floored[0].cnr < unfloored[0].cnr);
  // The fit itself is the same.
  CHECK(floored[0].m == unfloored[0].m);
}

TEST_CASE("placement_replaces: the better fit, and a fit's own m over a model-free one unless it fits far worse") {
  auto graded = [](ElementStatus s, double chi2, bool from_dips) {
    ElementResult r = ElementResult::of(2, 1, BarOrientation::vertical_bars, 5.0, 4.0);
    r.status = s;
    r.chi2_reduced = chi2;
    r.m_from_dips = from_dips;
    return r;
  };
  const ElementResult fit_ok = graded(ElementStatus::ok, 40, false), fit_ok_better = graded(ElementStatus::ok, 3, false);
  const ElementResult dips = graded(ElementStatus::ok, 20, true), clipped = graded(ElementStatus::clipped, 1, false);
  const ElementResult unfitted = graded(ElementStatus::fit_failed, 0, false);
  CHECK(placement_replaces(fit_ok_better, fit_ok));
  CHECK_FALSE(placement_replaces(fit_ok, fit_ok_better));
  CHECK_FALSE(placement_replaces(unfitted, fit_ok));
  CHECK(placement_replaces(fit_ok, unfitted));
  // chi^2 does not rank a model-free reading finely against a fit's own
  // (40 against 20: the fit wins)...
  CHECK(placement_replaces(fit_ok, dips));
  CHECK_FALSE(placement_replaces(dips, fit_ok));
  // ...but a fit the same model matches over 4 times worse than at the
  // model-free reading's placement sits off the bars (dev_14 turned by 5
  // degrees, G6E6 H: m 0.000 at chi^2 451 against m 0.43 at 47).
  ElementResult fit_off = graded(ElementStatus::ok, 451, false), dips_on = graded(ElementStatus::ok, 47, true);
  fit_off.m = 0.0;
  dips_on.m = 0.43;
  CHECK(placement_replaces(dips_on, fit_off));
  CHECK_FALSE(placement_replaces(fit_off, dips_on));
  // A fit that reads the bars as well as the dips keeps its place, however
  // much better the model fits there (near the noise, chi^2 10 against 2).
  ElementResult fit_on = graded(ElementStatus::ok, 10, false), dips_low = graded(ElementStatus::ok, 2, true);
  fit_on.m = 0.6;
  dips_low.m = 0.5;
  CHECK_FALSE(placement_replaces(dips_low, fit_on));
  CHECK(placement_replaces(fit_on, dips_low));
  CHECK(placement_replaces(dips, clipped));
  CHECK_FALSE(placement_replaces(clipped, dips));
}

TEST_CASE("placement_replaces: between two fits, the one whose gaps read clearly deeper is on the bars") {
  auto fitted = [](double chi2, double m, double dips_m, double dips_m_sigma) {
    ElementResult r = ElementResult::of(6, 6, BarOrientation::horizontal_bars, 114.0, 1.7);
    r.status = ElementStatus::ok;
    r.chi2_reduced = chi2;
    r.m = m;
    r.dips_m = dips_m;
    r.dips_m_sigma = dips_m_sigma;
    return r;
  };
  // dev_14 turned by 12 degrees, G6E6 H: beside its bars m 0.00 at chi^2
  // 178, the gaps 0.06 +- 0.02; on them m 0.45 at 395, the gaps 0.47 +- 0.07.
  const ElementResult beside = fitted(178, 0.0, 0.064, 0.019), on = fitted(395, 0.45, 0.471, 0.071);
  CHECK(placement_replaces(on, beside));
  CHECK_FALSE(placement_replaces(beside, on));
  // Readings within 3 combined sigma of each other do not tell: chi^2 does.
  const ElementResult near = fitted(395, 0.45, 0.15, 0.071);
  CHECK_FALSE(placement_replaces(near, beside));
  CHECK(placement_replaces(beside, near));
  // Without a reading at one of them (no dips there), chi^2 as well.
  const ElementResult unread = fitted(395, 0.45, 0.0, 0.0);
  CHECK_FALSE(placement_replaces(unread, beside));
}
