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

// The element's bars as artwork shapes.
std::vector<ArtworkShape> bar_shapes(const ElementLayout& e) {
  std::vector<ArtworkShape> shapes;
  for (const RectMm& b : e.bars_mm) shapes.push_back({ArtworkShape::Kind::rect, ArtworkShape::Role::bar, b, {}, 0, {}});
  return shapes;
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
  const IndexedArtwork artwork(bar_shapes(e));
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

namespace {

// A plane whose image scale across x grows linearly, as through a lens
// whose magnification changes over the field: x_px = cx + s0 (x + k x^2 / 2).
struct StretchedPlane final : PlaneToImage {
  Vec2 center_px{200, 100};
  double s0_px_per_mm = 30, k_per_mm = 0.06;
  std::optional<Vec2> project(Vec2 p) const override {
    return Vec2{center_px.x + s0_px_per_mm * (p.x + 0.5 * k_per_mm * p.x * p.x), center_px.y + s0_px_per_mm * p.y};
  }
  double px_per_mm_across(Vec2 p, BarOrientation bars) const override {
    return bars == BarOrientation::vertical_bars ? s0_px_per_mm * (1 + k_per_mm * p.x) : s0_px_per_mm;
  }
};

}  // namespace

TEST_CASE("a wide strip whose image scale changes is binned so that a pixel-space blur fits as one blur") {
  // A dark 2 mm square (a reference patch) blurred by a Gaussian of 1.5 px:
  // the same in pixels at both edges, but 12 % wider in mm at the left edge
  // than at the right one (scale 30 px/mm x (1 -+ 0.06)). Binned in mm, the
  // profile model's single blur fitted these edges with a reduced chi^2 of
  // several; binned in pixels over the centre's scale, they fit to the noise,
  // with the centre's blur.
  const StretchedPlane plane;
  const double sigma_px = 1.5, noise = 1e-3;
  cv::Mat lum(200, 400, CV_32F);
  cv::RNG rng(11);
  const double x_left = plane.project({-1, 0})->x, x_right = plane.project({1, 0})->x;
  auto cdf = [](double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); };
  for (int y = 0; y < lum.rows; ++y)
    for (int x = 0; x < lum.cols; ++x) {
      const double inside = cdf((x_right - x) / sigma_px) - cdf((x_left - x) / sigma_px);
      lum.at<float>(y, x) = float(0.8 * (1 - 0.7 * inside) + rng.gaussian(noise));
    }
  std::vector<ArtworkShape> shapes{{ArtworkShape::Kind::rect, ArtworkShape::Role::patch, {-1, -1, 1, 1}, {}, 0, {}}};
  const IndexedArtwork artwork(shapes);
  Strip strip;
  strip.center_mm = {0, 0};
  strip.bars = BarOrientation::vertical_bars;
  strip.half_u_mm = 1.3;
  strip.half_v_mm = 0.6;
  strip.extend_u_mm = 0.5;
  ProfileSamplingOptions so;
  so.bin_px = 0.5;
  const SampledProfile p = sample_strip(lum, plane, artwork, strip, so, 0);
  REQUIRE(p.in_view);
  ProfileFitOptions fo;
  fo.fit_contrast = true;
  fo.fit_shape = false;  // a Gaussian, as the patch is fitted
  fo.quadratic_background = true;
  const ProfileFit fit = fit_profile(p.data, fo);
  REQUIRE(fit.usable);
  CHECK(fit.chi2_reduced < 1.5);
  CHECK(fit.contrast == doctest::Approx(-0.7).epsilon(0.01));
  // T(nu) = exp(-(nu / nu0)^2) for a Gaussian of sd sigma: nu0 = 1 / (sqrt(2) pi sigma), sigma in mm at the centre.
  const double nu0_true = 1 / (std::sqrt(2.0) * M_PI * sigma_px / plane.s0_px_per_mm);
  CHECK(fit.nu0_per_mm == doctest::Approx(nu0_true).epsilon(0.02));
}

TEST_CASE("clipped pixels make their bins bounds: black an upper, saturation a lower one") {
  // Bars at 0 (clipped at black) on a ground at the clip level 1 (clipped
  // at saturation), with an unclipped grey band between.
  const ElementLayout e = triplet(0.1);
  ProfileSamplingOptions so;
  const Strip strip = element_strip(e, so);
  const double px_per_mm = 60;
  cv::Mat lum(400, 400, CV_32F, cv::Scalar(1.0));
  for (int y = 0; y < lum.rows; ++y)
    for (int x = 0; x < lum.cols; ++x) {
      const double u_mm = (x - 200) / px_per_mm;
      for (const RectMm& b : e.bars_mm)
        if (u_mm >= b.x0 && u_mm < b.x1) lum.at<float>(y, x) = 0.f;
      if (std::abs(u_mm) > 0.32 && std::abs(u_mm) < 0.36) lum.at<float>(y, x) = 0.5f;
    }
  const IndexedArtwork artwork(bar_shapes(e));
  const PatternFrame frame({200, 200}, {1, 0}, px_per_mm);
  const SampledProfile p = sample_strip(lum, frame, artwork, strip, so, 1.0);
  REQUIRE(p.in_view);
  REQUIRE(p.data.bound.size() == size_t(p.data.bin_count));
  int upper = 0, lower = 0, measured = 0;
  for (int b = 0; b < p.data.bin_count; ++b) {
    if (p.data.count[b] == 0) continue;
    const double v = p.data.value[b];
    if (v < 0.01) {
      CHECK(p.data.bound[b] == -1);
      ++upper;
    } else if (v > 0.99) {
      CHECK(p.data.bound[b] == 1);
      ++lower;
    } else if (std::abs(v - 0.5) < 0.01) {
      CHECK(p.data.bound[b] == 0);
      ++measured;
    }
  }
  CHECK(upper > 10);
  CHECK(lower > 10);
  CHECK(measured > 2);
  // With no clip level, nothing is a bound.
  CHECK(sample_strip(lum, frame, artwork, strip, so, 0).data.bound.empty());
}

// Bars a little above black under noise clip in most of their bins, and
// those bins are read past the clipping (censored_level.h): measurements at
// the bars' level with an honest error, where as bounds they held none.
// (At 200 px/mm each bin holds ~70 pixels; a bin with fewer than 8
// unclipped stays a bound.)
TEST_CASE("bins clipped at black under noise are read past the clipping, not left as bounds") {
  const ElementLayout e = triplet(0.1);
  ProfileSamplingOptions so;
  const Strip strip = element_strip(e, so);
  const double px_per_mm = 200, bar_level = 0.01, ground = 0.5, noise_sd = 0.02;
  cv::Mat lum(400, 400, CV_32F, cv::Scalar(ground));
  for (int y = 0; y < lum.rows; ++y)
    for (int x = 0; x < lum.cols; ++x) {
      const double u_mm = (x - 200) / px_per_mm;
      for (const RectMm& b : e.bars_mm)
        if (u_mm >= b.x0 && u_mm < b.x1) lum.at<float>(y, x) = static_cast<float>(bar_level);
    }
  cv::Mat noise(lum.size(), CV_32F);
  cv::setRNGSeed(5);
  cv::randn(noise, 0, noise_sd);
  lum = cv::max(lum + noise, 0.0);  // clipped at black, as a sensor clips
  const IndexedArtwork artwork(bar_shapes(e));
  const PatternFrame frame({200, 200}, {1, 0}, px_per_mm);
  const SampledProfile p = sample_strip(lum, frame, artwork, strip, so, 1.0);
  REQUIRE(p.in_view);
  CHECK(p.pixels_clipped > 0.1 * p.pixels_used);
  int read = 0, bounds = 0, covered = 0;
  for (int b = p.data.fit_begin; b < p.data.fit_end; ++b) {
    const double u = p.data.bin_center_mm(b);
    if (p.data.count[b] == 0 || p.data.ideal_at(u) < 0.999) continue;
    // Well inside a bar (a quarter bar from its edges): the level is known.
    bool inside = false;
    for (const RectMm& r : e.bars_mm) inside = inside || (u > r.x0 + 0.025 && u < r.x1 - 0.025);
    if (!inside) continue;
    if (p.data.bound_at(b) != 0) {
      ++bounds;
      continue;
    }
    ++read;
    covered += std::abs(p.data.value[b] - bar_level) <= 2 * p.data.sigma[b];
  }
  CHECK(read > 20);
  CHECK(bounds <= read / 10);
  CHECK(covered >= 0.85 * read);
}

namespace {

// Three bars of w mm drawn dark (0.1) on light (0.8) through `plane`
// (which stretches x only), blurred by 20 px, with noise of 0.02.
cv::Mat drawn_triplet(const ElementLayout& e, const PlaneToImage& plane, cv::Size size) {
  cv::Mat lum(size, CV_32F, cv::Scalar(0.8));
  for (const RectMm& b : e.bars_mm) {
    const Vec2 a = *plane.project({b.x0, b.y0}), c = *plane.project({b.x1, b.y1});
    cv::rectangle(lum, cv::Point(int(std::lround(a.x)), int(std::lround(a.y))),
                  cv::Point(int(std::lround(c.x)) - 1, int(std::lround(c.y)) - 1), cv::Scalar(0.1), cv::FILLED);
  }
  cv::GaussianBlur(lum, lum, {0, 0}, 20);
  cv::Mat noise(lum.size(), CV_32F);
  cv::setRNGSeed(7);
  cv::randn(noise, 0, 0.02);
  return lum + noise;
}

// triplet(w_mm) drawn (drawn_triplet) through a plane stretched 6 % per mm
// at 200 px/mm, centred in a size_px square; its strip read with bins 8 px
// wide as the options read it, and every pixel.
struct TwoReads {
  ProfileSamplingOptions options;
  SampledProfile read, every_pixel;
};
TwoReads read_and_read_whole(double w_mm, int size_px) {
  const ElementLayout e = triplet(w_mm);
  TwoReads r;
  r.options.bin_px = 8;
  r.options.along_fraction = 0.7;
  r.options.margin_bar_widths = 1.5;
  const Strip strip = element_strip(e, r.options);
  StretchedPlane plane;
  plane.center_px = {0.5 * size_px, 0.5 * size_px};
  plane.s0_px_per_mm = 200;
  const cv::Mat lum = drawn_triplet(e, plane, {size_px, size_px});
  const IndexedArtwork artwork(bar_shapes(e));
  ProfileSamplingOptions every_pixel = r.options;
  every_pixel.dense_bin_samples = 1e6;
  r.read = sample_strip(lum, plane, artwork, strip, r.options, 0);
  r.every_pixel = sample_strip(lum, plane, artwork, strip, every_pixel, 0);
  return r;
}

}  // namespace

TEST_CASE("a strip hundreds of px wide is read on an odd stride, and fits the same m") {
  // Three bars of 0.5 mm at about 200 px/mm (100 px per bar) through a lens
  // whose scale grows 6 % per mm across the bars (so the pixel -> (u, v)
  // map's higher differences, stepped over k pixels, matter), with bins 8
  // px wide: a bin holds about 8 x 350 pixels (bars 500 px long, 70 % of
  // them read), over 9 x the dense-bin count, so every 3rd row and column
  // is read.
  const TwoReads reads = read_and_read_whole(0.5, 1400);
  const ProfileSamplingOptions& so = reads.options;
  const SampledProfile &all = reads.every_pixel, &strided = reads.read;
  REQUIRE(all.in_view);
  REQUIRE(strided.in_view);
  // Every 3rd row and column: a ninth of the pixels, up to the edges.
  CHECK(strided.pixels_used * 9 == doctest::Approx(all.pixels_used).epsilon(0.02));
  REQUIRE(strided.data.bin_count == all.data.bin_count);
  for (int b = all.data.fit_begin; b < all.data.fit_end; ++b)
    if (all.data.count[b] > 0) {
      // 2 or 3 of a bin's 8 columns are read: at least half the average.
      REQUIRE(strided.data.count[b] >= 0.5 * so.dense_bin_samples);
      // Each bin's samples sit where the whole read's do, to a third of a bin.
      CHECK(std::abs(strided.data.u_mean_mm[b] - all.data.u_mean_mm[b]) < all.data.bin_mm / 3);
    }
  // The bins' means sit at their samples' mean positions, which the stride
  // moves: compared through the model, both read the blur alike, and right
  // (20 px at the centre's 200 px/mm, a Gaussian of 0.1 mm: m(1 lp/mm) =
  // exp(-2 pi^2 0.1^2) = 0.821).
  ProfileFitOptions fo;
  fo.contrast = 0.1 / 0.8 - 1;
  const ProfileFit fit_all = fit_profile(all.data, fo), fit_strided = fit_profile(strided.data, fo);
  REQUIRE(fit_all.usable);
  REQUIRE(fit_strided.usable);
  const double m_all = fit_all.transfer(1), m_strided = fit_strided.transfer(1);
  const double sigma = fit_strided.transfer_sigma(1);
  CHECK(sigma > 0);
  CHECK(std::abs(m_strided - m_all) < 2 * sigma);
  CHECK(std::abs(m_strided - std::exp(-2 * M_PI * M_PI * 0.01)) < 3 * sigma + 0.01);
  CHECK(strided.noise_sd == doctest::Approx(all.noise_sd).epsilon(0.1));
}

TEST_CASE("a strip of ordinary density is read whole") {
  // Bars of 0.2 mm (40 px) with bins 8 px wide: about 8 x 140 pixels a
  // bin, under 9 x the dense-bin count.
  const TwoReads reads = read_and_read_whole(0.2, 600);
  const SampledProfile &whole = reads.read, &reference = reads.every_pixel;
  REQUIRE(whole.in_view);
  CHECK(whole.pixels_used == reference.pixels_used);
  CHECK(whole.data.count == reference.data.count);
  for (int b = 0; b < whole.data.bin_count; ++b)
    if (whole.data.count[b] > 0) CHECK(whole.data.value[b] == reference.data.value[b]);  // empty bins: NaN
}
