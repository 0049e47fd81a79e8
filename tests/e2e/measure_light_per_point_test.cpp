// End to end: relief captures under a light that varies over the target
// (the shading's light per point, as the `light_path` effect gives it),
// measured against their truth. The level step then varies over the target
// and the measurement normalises each element by its gain field
// (metrology/measure gain_field.h).
#include <cmath>
#include <memory>
#include <string>
#include <variant>

#include <doctest/doctest.h>
#include <nlohmann/json.hpp>

#include "limit_checks.h"
#include "scene_fixtures.h"
#include "tactres/measure/gain_field.h"
#include "tactres/measure/measurement_io.h"

using namespace tactres;
using namespace tactres::testing;

namespace {

struct Outcome {
  Measurement m;
  Truth truth;
};

// A light whose azimuth stays at 30 degrees (target frame) while its
// in-plane part grows from 0.3 to 1.1 of the normal one across the target
// (x from -10 to +10 mm about the centre): the shading gain of both bar
// orientations changes 3.7x from one side to the other, linearly, with one
// direction everywhere (the modelled light paths, whose direction turns as
// well, are measure_light_path_test.cpp's). Applied to a scene under one
// light (tests/data/scenes). `curvature_per_mm2` bends the sweep (the field
// a plane cannot follow).
class SweptLight final : public InPlaneLightMap {
 public:
  explicit SweptLight(double curvature_per_mm2 = 0) : curvature_(curvature_per_mm2) {}
  Vec2 in_plane_fraction_at(Vec2 offset_mm) const override {
    const double r2 = offset_mm.x * offset_mm.x + offset_mm.y * offset_mm.y;
    const double s = 0.7 + 0.04 * offset_mm.x + curvature_ * (r2 - 50.0);
    return {s * std::cos(kAzimuthRad), s * std::sin(kAzimuthRad)};
  }
  static constexpr double kAzimuthRad = 30.0 * 3.141592653589793 / 180.0;

 private:
  double curvature_;
};

Outcome render_and_measure(const std::string& design, bool swept, double curvature_per_mm2 = 0) {
  TempDir dir("light-per-point");
  Scene scene = read_scene_file(source_dir() / "tests/data/scenes" / (design + ".json"));
  const CameraModel camera = CameraModel::load(scene.camera_path);
  if (swept)
    for (Effect& e : scene.effects)
      if (auto* sh = std::get_if<ShadingEffect>(&e)) sh->light_map = std::make_shared<SweptLight>(curvature_per_mm2);
  const Rendered r = render_to_file(scene, camera, dir.path, design);
  return {measure_file(r.file, &camera), r.truth};
}

// The optical limit of each orientation the truth resolves, within the
// noisy-scene tolerance (3 %, measure_relief_test.cpp) and by the discrete
// rule; every ok element's m against the truth's within its own error and
// the shading model's bias.
void check_optical(const std::string& design, const Outcome& o) {
  const Measurement& m = o.m;
  CAPTURE(design);
  CAPTURE(m.problem);
  REQUIRE(m.usable);
  CHECK(m.reference.signature == Signature::shading);
  for (const BarOrientation orient : {BarOrientation::horizontal_bars, BarOrientation::vertical_bars}) {
    const bool h = orient == BarOrientation::horizontal_bars;
    const Limit& measured = (h ? m.horizontal_parts : m.vertical_parts).optical;
    const Limit& true_limit = (h ? o.truth.horizontal_parts : o.truth.vertical_parts).optical;
    CAPTURE(h);
    const double rel = check_limit(measured, true_limit, 0.03);  // the noisy-scene tolerance
    if (measured.interpolated_lp_per_mm && true_limit.interpolated_lp_per_mm)
      MESSAGE(design << (h ? " H" : " V") << ": optical limit " << *measured.interpolated_lp_per_mm << " vs true "
                     << *true_limit.interpolated_lp_per_mm << " lp/mm (" << 100 * rel << " %), field "
                     << std::string(m.reference.field(orient).plane ? "plane" : "uniform") << ", spread "
                     << m.reference.field(orient).spread);
  }
  int ok = 0;
  for (const ElementResult& e : m.elements) {
    if (e.status != ElementStatus::ok) continue;
    const TruthElement* te = truth_of(o.truth, e);
    REQUIRE(te);
    CAPTURE(e.group);
    CAPTURE(e.element);
    const std::string orientation = to_string(e.orientation);
    CAPTURE(orientation);
    CHECK(std::abs(e.m - te->m) <= 3 * e.m_sigma + 0.03);
    ++ok;
  }
  CHECK(ok >= 8);
}

}  // namespace

TEST_CASE("light per point: a light whose strength sweeps across the target: the optical limit and m hold") {
  const Outcome o = render_and_measure("T1C1", true);
  // The step changes 3.7x over the target: both fields are planes, and
  // without them the elements far from the patch would read m off by that
  // ratio (the per-element check below would fail).
  CHECK(o.m.reference.vertical_field.plane);
  CHECK(o.m.reference.horizontal_field.plane);
  CHECK(o.m.reference.vertical_field.spread > kStronglyNonUniformSpread);
  check_optical("T1C1 swept", o);
  // Reported: the field in the JSON (no NaN anywhere), and a warning.
  const nlohmann::json j = measurement_to_json(o.m, {});
  REQUIRE(j["reference"].contains("gain_field"));
  const nlohmann::json& v = j["reference"]["gain_field"]["vertical_bars"];
  CHECK(v["model"] == "plane");
  CHECK(v["gradient_per_mm"][0].is_number());
  CHECK(v["samples"].get<int>() >= 4);
  CHECK(j.dump().find("NaN") == std::string::npos);
  bool warned = false;
  for (const std::string& w : o.m.warnings) warned = warned || w.find("strongly non-uniform") != std::string::npos;
  CHECK(warned);
}

TEST_CASE("light per point: one light everywhere keeps the patch's step (uniform field)") {
  const Outcome o = render_and_measure("T1C1", false);
  CHECK_FALSE(o.m.reference.vertical_field.plane);
  CHECK_FALSE(o.m.reference.horizontal_field.plane);
  CHECK_FALSE(measurement_to_json(o.m, {})["reference"].contains("gain_field"));
  check_optical("T1C1", o);
}

TEST_CASE("light per point: a curved sweep (beyond a plane): the plane's misfit widens the errors, the limit holds") {
  // The in-plane part 0.7 + 0.04 x + 0.003 (r^2 - 50): 0.55 at the centre,
  // 0.75-1.55 at the corners, a bowl a plane cannot follow (as T1's spot,
  // whose in-plane part grows faster than linearly off the axis).
  const Outcome o = render_and_measure("T1C1", true, 0.003);
  CHECK(o.m.reference.vertical_field.plane);
  MESSAGE("curved: plane chi2 " << o.m.reference.vertical_field.chi2_reduced << " (V), "
                                << o.m.reference.horizontal_field.chi2_reduced << " (H)");
  check_optical("T1C1 curved", o);
}
