// Disc candidates (fiducial_candidates.cpp): either polarity, small discs at
// full resolution, and nothing taken for a target where there is none.


#include <string>

#include <doctest/doctest.h>
#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "fiducials_test_support.h"
#include "tactres/locate/fiducials.h"
#include "tactres/targets/layout.h"

using namespace tactres;
using namespace tactres::fiducial_test;

TEST_CASE("fiducials: light bars on dark, and a wrong polarity hint") {
  Case c = base_case("light on dark");
  c.layout = make_layout({.polarity = Polarity::light_bars_on_dark});
  c.spec.ground = 0.08;
  c.spec.ink = 0.85;
  c.view.roll_deg = 140;
  Outcome o = run(c);
  check_all_found(o, 0.05);
  CHECK_FALSE(o.result.dark_on_light);
  for (const auto& d : o.result.discs) CHECK(d.contrast > 0.5);

  // The layout says light-on-dark but the capture is dark-on-light (a relief
  // through a gel can show either): the other polarity is tried.
  c.name = "dark capture, light layout";
  c.spec = {};
  o = run(c);
  check_all_found(o, 0.05);
  CHECK(o.result.dark_on_light);
  for (const auto& d : o.result.discs) CHECK(d.contrast < -0.5);
}

TEST_CASE("fiducials: small target (discs of ~4 px radius) at full resolution") {
  Case c = base_case("small discs r=4 px");
  c.view.distance_mm = 180;  // 6.7 px/mm: r = 4 px, found at full resolution only
  c.view.roll_deg = 33;
  check_all_found(run(c), 0.05);
}

TEST_CASE("fiducials: no target") {
  const TargetLayout L = make_layout({});
  {
    cv::Mat blank(600, 800, CV_32F, cv::Scalar(0.5));
    const auto r = find_fiducials(blank, L);
    CHECK_FALSE(r.found);
    CHECK(r.problem.find("no target found") != std::string::npos);
  }
  for (double blur : {2.0, 6.0, 12.0}) {
    // Random texture: blurred noise has round blobs of every size.
    cv::Mat tex(600, 800, CV_32F);
    cv::RNG rng(777);
    rng.fill(tex, cv::RNG::NORMAL, 0.5, 0.2);
    cv::GaussianBlur(tex, tex, cv::Size(0, 0), blur);
    const auto r = find_fiducials(tex, L);
    CHECK_FALSE(r.found);
    CHECK_FALSE(r.problem.empty());
    MESSAGE(fmt::format("random texture blur {}: {}", blur, r.problem));
  }
  {
    // Scattered discs of about the right size, in no particular pattern.
    cv::Mat img(600, 800, CV_32F, cv::Scalar(0.8));
    cv::RNG rng(99);
    for (int i = 0; i < 30; ++i)
      cv::circle(img, cv::Point(rng.uniform(30, 770), rng.uniform(30, 570)), rng.uniform(8, 16),
                 cv::Scalar(0.1), cv::FILLED, cv::LINE_AA);
    const auto r = find_fiducials(img, L);
    CHECK_FALSE(r.found);
    MESSAGE("30 random discs: " << r.problem);
  }
  {
    Case c = base_case("only bars, labels and patch");
    c.spec.drop_fiducials = true;
    c.view.tilt_deg = 20;
    const Outcome o = run(c);
    CHECK_FALSE(o.result.found);
    CHECK(o.result.problem.find("no target found") != std::string::npos);
  }
}
