// End to end: relief-through-gel design scenes under one light each (the
// illustrative scenes the examples shipped before the light path was
// modelled, tests/data/scenes: one gain and one light direction per design)
// measured against their truth files. The modelled examples/scenes, whose
// light turns over the target, are measure_light_path_test.cpp's.
#include <cmath>

#include <doctest/doctest.h>

#include "limit_checks.h"
#include "scene_fixtures.h"

using namespace tactres;
using namespace tactres::testing;

namespace {

void check_design(const std::string& design) {
  TempDir dir("relief");
  const Scene scene = read_scene_file(source_dir() / "tests/data/scenes" / (design + ".json"));
  const CameraModel camera = CameraModel::load(scene.camera_path);
  REQUIRE(scene.target == TargetKind::relief);
  const RenderResult r = render_scene(scene, default_layout(), camera);
  const auto file = dir.path / (design + ".png");
  write_image(file, r.image, r.bits);
  const Truth truth = compute_truth(scene, default_layout(), camera);
  const Measurement m = measure_file(file, &camera);
  CAPTURE(design);
  CAPTURE(m.problem);
  REQUIRE(m.usable);
  CHECK(m.pose.seen_from_behind);
  CHECK(m.reference.signature == Signature::shading);
  for (const auto& [measured, true_limit] : {std::pair(m.horizontal, truth.horizontal), std::pair(m.vertical, truth.vertical)}) {
    // The light path decides which bar orientation the shading reaches
    // (docs/LIGHT_PATH.md): with the LEDs on the sensor's x axis, horizontal
    // bars get almost no in-plane light. An orientation the truth resolves
    // nowhere must not be claimed by the measurement either.
    const double rel = check_limit(measured, true_limit, 0.03);  // the noisy-scene tolerance
    if (!true_limit.any_resolved) continue;
    MESSAGE(design << ": limit " << *measured.interpolated_lp_per_mm << " vs true " << *true_limit.interpolated_lp_per_mm
                   << " lp/mm (" << 100 * rel << " %), pose RMS " << m.pose.rms_px << " px");
  }
}

}  // namespace

TEST_CASE("relief through gel: T1C1 (light from above) limits agree with the truth") { check_design("T1C1"); }

TEST_CASE("relief through gel: T1C4 (15 x 33 mm aperture) limits agree with the truth") { check_design("T1C4"); }

TEST_CASE("relief through gel: T1C2 and T1C3 limits agree with the truth") {
  check_design("T1C2");
  check_design("T1C3");
}

// T2: light guided through the elastomer's edge: dimmer and more oblique
// than T1 (docs/LIGHT_PATH.md).
TEST_CASE("relief through gel: T2C1-T2C4 (edge-lit) limits agree with the truth") {
  for (const char* design : {"T2C1", "T2C2", "T2C3", "T2C4"}) check_design(design);
}
