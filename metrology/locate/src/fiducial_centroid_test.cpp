// Centroids (fiducial_centroid.cpp, fiducial_relief.cpp) on synthetic
// captures: illumination gradients, noise and blur, rings, crescents, and
// small blurred crescents that must not pass for printed discs.

#include <string>

#include <doctest/doctest.h>
#include <fmt/format.h>

#include "fiducials_test_support.h"
#include "tactres/locate/fiducials.h"

using namespace tactres;
using namespace tactres::fiducial_test;

TEST_CASE("fiducials: illumination gradient, noise and blur") {
  // One capture per row: what departs from the clean, fronto-parallel view,
  // and the largest centroid error allowed (px).
  struct Variant {
    const char* name;
    bool gradient = false;  // 3:1 across the image
    double noise_sigma = 0, blur_sigma_px = 0;
    double roll_deg = 0, tilt_deg = 0, tilt_axis_deg = 0;
    bool mirrored = false;
    double max_err_px = 0.05;
  };
  const Variant variants[] = {
      {.name = "3:1 illumination gradient", .gradient = true, .roll_deg = 20},
      {.name = "gradient + tilt 30", .gradient = true, .tilt_deg = 30, .tilt_axis_deg = 60},
      {.name = "noise sigma 2% of contrast", .noise_sigma = 0.014, .roll_deg = 75, .max_err_px = 0.1},
      {.name = "noise sigma 10% of contrast", .noise_sigma = 0.07, .roll_deg = 75, .max_err_px = 0.3},
      {.name = "blur sigma 1.5 px", .blur_sigma_px = 1.5, .roll_deg = 310},
      {.name = "blur 1.5 + noise 2% + gradient + tilt",
       .gradient = true,
       .noise_sigma = 0.014,
       .blur_sigma_px = 1.5,
       .tilt_deg = 40,
       .tilt_axis_deg = 20,
       .mirrored = true,
       .max_err_px = 0.1},
  };
  for (const Variant& v : variants) {
    Case c = base_case(v.name);
    c.gradient = v.gradient;
    c.noise_sigma = v.noise_sigma;
    c.blur_sigma_px = v.blur_sigma_px;
    c.view.roll_deg = v.roll_deg;
    c.view.tilt_deg = v.tilt_deg;
    c.view.tilt_axis_deg = v.tilt_axis_deg;
    c.view.mirrored = v.mirrored;
    check_all_found(run(c), v.max_err_px);
  }
}

TEST_CASE("fiducials: relief through a gel: discs seen as rings of either polarity") {
  for (int sign : {-1, 1}) {
    for (double tilt : {0.0, 30.0}) {
      Case c = base_case(fmt::format("{} rings, tilt {}", sign < 0 ? "dark" : "light", tilt));
      c.ring_sign = sign;
      c.view.tilt_deg = tilt;
      c.view.tilt_axis_deg = 70;
      c.view.roll_deg = 160;
      c.view.mirrored = true;
      const Outcome o = run(c);
      REQUIRE(o.result.found);
      CHECK(ids(o.result) == kAll);
      CHECK(o.result.dark_on_light == (sign < 0));
      CHECK_FALSE(o.result.shaded);
      // A ring's centroid is its centre: exact when fronto-parallel; under
      // perspective it is not the disc's area centroid (reported, ~0.02 px).
      CHECK(o.max_err_px < (tilt == 0 ? 0.05 : 0.1));
    }
  }
}

TEST_CASE("fiducials: relief under a directional light: discs seen as two crescents") {
  for (double az : {0.0, 35.0, 100.0}) {
    for (double tilt : {0.0, 30.0}) {
      Case c = base_case(fmt::format("crescents, light {} deg, tilt {}", az, tilt));
      c.directional = true;
      c.light_azimuth_deg = az;
      c.view.tilt_deg = tilt;
      c.view.tilt_axis_deg = 20;
      c.view.roll_deg = 50;
      const Outcome o = run(c);
      REQUIRE(o.result.found);
      CHECK(ids(o.result) == kAll);
      CHECK(o.result.shaded);
      CHECK_FALSE(o.result.dark_on_light);
      CHECK(o.max_err_px < (tilt == 0 ? 0.05 : 0.1));
    }
  }
}

TEST_CASE("fiducials: small blurred relief discs: crescents are not taken for printed discs") {
  // 1280x720, 560 px focal length, 60-70 mm: discs of 4.8-5.6 px radius,
  // blurred by ~3 px. Each crescent is then a compact blob that passes for a
  // small printed disc, and the five dark crescents fit the pattern (all
  // displaced alike, ~a radius off the discs). The dark-disc mode, tried
  // first for this (dark-on-light) layout, used to accept them: centroids
  // ~5 px off, or four discs mislabelled, with no warning. Each must now be
  // the shaded discs, or refused as crescents; never printed discs.
  int shaded = 0, runs = 0;
  for (double distance : {60.0, 70.0})
    for (double roll : {0.0, 50.0}) {
      Case c = base_case(fmt::format("small relief discs, {} mm, roll {}", distance, roll));
      c.view.size = {1280, 720};
      c.view.focal_px = 560;
      c.view.distance_mm = distance;
      c.view.roll_deg = roll;
      c.view.mirrored = true;
      c.directional = true;
      c.light_azimuth_deg = 35;
      c.blur_sigma_px = 2.8;
      c.noise_sigma = 0.002;
      const Outcome o = run(c);
      ++runs;
      if (!o.result.found) {
        CHECK_FALSE(o.result.problem.empty());
        continue;
      }
      CHECK_FALSE(o.result.dark_on_light);
      CHECK(o.result.shaded);
      CHECK(ids(o.result) == kAll);
      CHECK(o.max_err_px < 1.0);
      shaded += o.result.shaded;
    }
  MESSAGE(fmt::format("small relief discs: {} of {} found as shaded discs, the rest refused",
                      shaded, runs));
  CHECK(shaded >= 2);  // at 70 mm the rims are fitted (measured: 60 mm refused)
}
