// fibre_lattice_pitch_px (fibre_lattice.cpp): a coherent fibre bundle's
// honeycomb is found over a chart at any turn, with its rows' pitch; bars,
// a grating of one direction, noise and small images give none.

#include <cmath>
#include <cstdint>
#include <numbers>

#include <doctest/doctest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "chart_detect_internal.h"
#include "fibre_bundle.h"

using namespace tactres::locate_detail;
using namespace tactres::testing;

namespace {

// Three-bar patterns of bar widths 3-12 px in both orientations, dark
// (0.2) on a ground of 0.9, over a 400 px square.
bool on_bar(int x, int y) {
  const int widths[] = {3, 4, 5, 6, 8, 10, 12};
  for (int i = 0; i < 7; ++i) {
    const int w = widths[i], x0 = 20 + 52 * i, y0 = 40;
    for (int b = 0; b < 3; ++b) {
      const bool vertical = x >= x0 + 2 * b * w && x < x0 + 2 * b * w + w && y >= y0 && y < y0 + 5 * w;
      const bool horizontal = x >= x0 && x < x0 + 5 * w && y >= 220 + 2 * b * w && y < 220 + 2 * b * w + w;
      if (vertical || horizontal) return true;
    }
  }
  return false;
}

// The bars seen through a bundle of cores `spacing_px` apart, its
// domains turned by about `turn_deg` (FibreBundle; no bundle: spacing 0),
// with noise of sigma 0.02.
cv::Mat chart_view(double spacing_px, double turn_deg, bool bars = true, std::uint64_t seed = 0) {
  cv::Mat img(400, 400, CV_32F);
  const FibreBundle bundle(spacing_px > 0 ? spacing_px : 1, turn_deg, img.cols, img.rows, 12,
                           seed ? seed : static_cast<uint64_t>(100 * spacing_px + turn_deg) + 1);
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x) {
      const double fibres = spacing_px > 0 ? bundle.transmission(x, y) : 1.0;
      img.at<float>(y, x) = static_cast<float>(fibres * (bars && on_bar(x, y) ? 0.2 : 0.9));
    }
  cv::Mat noise(img.size(), CV_32F);
  cv::RNG rng(seed + 7);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 0.02);
  return img + noise;
}

}  // namespace

TEST_CASE("a fibre bundle's honeycomb is found over a chart, with its rows' pitch") {
  for (const double spacing_px : {4.0, 4.5, 5.4, 8.0, 11.0})
    for (const double turn_deg : {0.0, 17.0, 45.0}) {
      CAPTURE(spacing_px);
      CAPTURE(turn_deg);
      const std::optional<double> pitch = fibre_lattice_pitch_px(chart_view(spacing_px, turn_deg));
      REQUIRE(pitch);
      // Rows of cores stand spacing x sqrt(3)/2 apart.
      CHECK(*pitch == doctest::Approx(spacing_px * std::sqrt(3.0) / 2).epsilon(0.04));
    }
}

TEST_CASE("bars, a grating of one direction, noise and small images show no fibre bundle") {
  CHECK_FALSE(fibre_lattice_pitch_px(chart_view(0, 0)));
  // A fine grating (bars 2.5 px wide) fills the centre: one pair of peaks,
  // not three.
  cv::Mat grating(400, 400, CV_32F);
  for (int y = 0; y < grating.rows; ++y)
    for (int x = 0; x < grating.cols; ++x)
      grating.at<float>(y, x) = static_cast<float>(0.5 + 0.4 * std::cos(2 * std::numbers::pi * (x + 0.3 * y) / 5.0));
  CHECK_FALSE(fibre_lattice_pitch_px(grating));
  cv::Mat noise(400, 400, CV_32F);
  cv::RNG rng(3);
  rng.fill(noise, cv::RNG::NORMAL, 0.5, 0.1);
  CHECK_FALSE(fibre_lattice_pitch_px(noise));
  cv::GaussianBlur(noise, noise, {0, 0}, 1.5);
  CHECK_FALSE(fibre_lattice_pitch_px(noise));
  // Smaller than the square the spectrum is taken of, even with a bundle.
  CHECK_FALSE(fibre_lattice_pitch_px(chart_view(5.4, 0)(cv::Rect(0, 0, 255, 400))));
}

TEST_CASE("a bundle coarser than 10 px per row gives none, never a harmonic's pitch") {
  // A hexagonal lattice also rings at sqrt(3), 2 and sqrt(7) times its
  // first radius; for coarse cores the sqrt(7) ring can stand out most.
  for (const bool bars : {false, true})
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
      CAPTURE(bars);
      CAPTURE(seed);
      for (const double spacing_px : {12.0, 14.0, 17.0}) {
        CAPTURE(spacing_px);
        CHECK_FALSE(fibre_lattice_pitch_px(chart_view(spacing_px, 10, bars, seed)));
      }
      // Rows 9.5 px apart: within range, found right or not at all.
      if (const std::optional<double> pitch = fibre_lattice_pitch_px(chart_view(11, 10, bars, seed)))
        CHECK(*pitch == doctest::Approx(11 * std::sqrt(3.0) / 2).epsilon(0.04));
    }
}
