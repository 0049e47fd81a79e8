// Identification (fiducial_identify.cpp, fiducial_verify.cpp): four discs
// of five, which labelling when T3 is hidden, and lines bent by a lens.


#include <string>
#include <vector>

#include <doctest/doctest.h>
#include <fmt/format.h>

#include "fiducials_test_support.h"
#include "tactres/locate/fiducials.h"

using namespace tactres;
using namespace tactres::fiducial_test;

TEST_CASE("fiducials: barrel distortion of a wide-angle lens") {
  // f = 500 px, target ~ 0.7 of the image height: with k1 = -0.25 the
  // target's corners are displaced by ~5 % (tens of px), bending every line.
  for (double k1 : {-0.1, -0.25}) {
    Case c = base_case(fmt::format("barrel distortion k1 = {}", k1));
    c.view.focal_px = 500;
    c.view.distance_mm = 25;
    c.view.k1 = k1;
    c.view.roll_deg = 15;
    c.view.tilt_deg = 20;
    const Outcome o = run(c);
    check_all_found(o, 0.05);
  }
}

TEST_CASE("fiducials: one disc occluded or out of view") {
  for (const std::string hidden : {"TL", "TR", "BL", "BR"}) {
    Case c = base_case("occluded " + hidden);
    c.spec.hidden = {hidden};
    c.view.roll_deg = 115;
    c.view.mirrored = hidden == "TR";
    const Outcome o = run(c);
    REQUIRE(o.result.found);
    std::vector<std::string> expect;
    for (const auto& id : kAll)
      if (id != hidden) expect.push_back(id);
    CHECK(ids(o.result) == expect);
    CHECK(o.result.warning.find(hidden) != std::string::npos);
    CHECK(o.max_err_px < 0.05);
  }
  {
    // With T3 hidden the four corners fit every symmetry of the rectangle;
    // only the reference patch tells the labellings apart.
    Case c = base_case("occluded T3");
    c.spec.hidden = {"T3"};
    c.view.roll_deg = 250;
    c.view.mirrored = true;
    const Outcome o = run(c);
    REQUIRE(o.result.found);
    CHECK(ids(o.result) == std::vector<std::string>{"TL", "TR", "BL", "BR"});
    CHECK(o.max_err_px < 0.05);
  }
  {
    // ... and without a patch to look at, no guessing.
    Case c = base_case("occluded T3, no patch");
    c.spec.hidden = {"T3"};
    c.spec.drop_patch = true;
    const Outcome o = run(c);
    CHECK_FALSE(o.result.found);
    CHECK(o.result.discs.empty());
    CHECK(o.result.problem.find("frame the whole target") != std::string::npos);
  }
  {
    // BR pushed out of the frame, with perspective.
    Case c = base_case("BR out of view");
    c.view.roll_deg = 45;  // BR straight below the centre, TR and BL level with it
    c.view.shift_px = {0, 100};
    c.view.tilt_deg = 25;
    c.view.tilt_axis_deg = 90;
    const Outcome o = run(c);
    REQUIRE(o.result.found);
    CHECK(ids(o.result) == std::vector<std::string>{"TL", "T3", "TR", "BL"});
  }
  {
    Case c = base_case("two discs hidden");
    c.spec.hidden = {"TL", "BR"};
    const Outcome o = run(c);
    CHECK_FALSE(o.result.found);
    CHECK(o.result.problem.find("of the 5 fiducial discs") != std::string::npos);
  }
}
