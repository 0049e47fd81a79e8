#include "tactres/profiles/profile_sampler.h"

#include <cmath>

#include <doctest/doctest.h>
#include <opencv2/imgproc.hpp>

#include "tactres/camera/plane_map.h"

using namespace tactres;

namespace {

// Three vertical bars of width w mm about the origin, drawn dark on light.
ElementLayout triplet(double w_mm) {
  ElementLayout e;
  e.bar_width_mm = w_mm;
  e.lp_per_mm = 0.5 / w_mm;
  e.orientation = BarOrientation::vertical_bars;
  for (int i = 0; i < 3; ++i) e.bars_mm[i] = {(2 * i - 2.5) * w_mm, -2.5 * w_mm, (2 * i - 1.5) * w_mm, 2.5 * w_mm};
  return e;
}

}  // namespace

TEST_CASE("a last-bit change of the image scale does not move the profile's bin grid") {
  // The scale is chosen so that the extended strip spans a whole number of
  // bins: the case where rounding once decided between n and n + 1 bins,
  // and an odd count moved every bin by half a bin.
  const ElementLayout e = triplet(0.1);
  ProfileSamplingOptions so;
  so.bin_px = 0.25;
  const Strip strip = element_strip(e, so);
  const double u_ext_mm = strip.half_u_mm + strip.extend_u_mm;
  const double px_per_mm = 129 * so.bin_px / (2 * u_ext_mm);  // 129 bins in exact arithmetic
  cv::Mat lum(400, 400, CV_32F, cv::Scalar(0.8));
  std::vector<ArtworkShape> shapes;
  for (const RectMm& b : e.bars_mm) shapes.push_back({ArtworkShape::Kind::rect, ArtworkShape::Role::bar, b, {}, 0, {}});
  const IndexedArtwork artwork(shapes);
  const double scales[] = {px_per_mm, px_per_mm * (1 + 1e-15), px_per_mm * (1 - 1e-15)};
  SampledProfile first;
  for (double s : scales) {
    const PatternFrame frame({200, 200}, {1, 0}, s);
    const SampledProfile p = sample_strip(lum, frame, artwork, strip, so, 0);
    REQUIRE(p.in_view);
    CHECK(p.data.bin_count % 2 == 0);
    if (first.data.bin_count == 0) {
      first = p;
      continue;
    }
    CHECK(p.data.bin_count == first.data.bin_count);
    CHECK(p.data.u0_mm == doctest::Approx(first.data.u0_mm).epsilon(1e-12));
  }
}
