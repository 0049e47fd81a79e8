// The light_path effect's light per point (docs/LIGHT_PATH.md): the
// renderer and the truth take the irradiance vector at each target point,
// checked here against the quadrature model itself (LightPathModel::at), not
// against the map the renderer interpolates.

#include <cmath>
#include <filesystem>
#include <string>
#include <utility>

#include <doctest/doctest.h>
#include <nlohmann/json.hpp>

#include "tactres/camera/camera_model.h"
#include "tactres/simulate/effects/light_path.h"
#include "tactres/simulate/effects/relief_field.h"
#include "tactres/simulate/renderer.h"
#include "tactres/simulate/scene.h"
#include "tactres/simulate/truth.h"
#include "tactres/targets/layout.h"

using namespace tactres;

namespace {

const std::filesystem::path kExamples = std::filesystem::path(TACTRES_SOURCE_DIR) / "examples";

Scene example_scene(const std::string& design) {
  return read_scene_file(kExamples / "scenes" / (design + ".json"));
}

// The model's E_t / E_n at a target point, target frame, straight from the
// quadrature (no table).
Vec2 model_fraction(const LightPathModel& model, const MembraneMapping& mapping, Vec2 offset_mm) {
  const IrradianceVector e = model.at(mapping.sensor_from_target_offset(offset_mm));
  const Vec2 t = mapping.target_from_sensor_vector({e.x_w_per_mm2, e.y_w_per_mm2});
  return {t.x / e.normal_w_per_mm2, t.y / e.normal_w_per_mm2};
}

MembraneMapping mapping_of(const Scene& s) {
  const ViewPose& v = *s.view_pose;
  return {{v.offset_mm[0], v.offset_mm[1]}, v.roll_deg, v.view == "through_gel"};
}

}  // namespace

TEST_CASE("light per point: the map's in-plane fraction is the model's, rotated into the target frame") {
  for (const char* design : {"T1C1", "T2C4"}) {
    CAPTURE(std::string(design));
    const Scene s = example_scene(design);
    const ShadingEffect* sh = s.find<ShadingEffect>();
    REQUIRE(sh);
    REQUIRE(sh->light_map);
    const LightPathModel model(s.light_path->options);
    const MembraneMapping mapping = mapping_of(s);
    for (const Vec2 o : {Vec2{0, 0}, Vec2{8, 0}, Vec2{-8, 0}, Vec2{0, 8}, Vec2{-6, -7}, Vec2{7, 5}}) {
      const Vec2 want = model_fraction(model, mapping, o);
      const Vec2 got = sh->light_map->in_plane_fraction_at(o);
      CAPTURE(o.x);
      CAPTURE(o.y);
      // The table's Catmull-Rom error is <= 2e-3 of |E_vec| where the bars
      // are: ~2e-3 of E_n on t, plus 0.5 % of t.
      CHECK(got.x == doctest::Approx(want.x).epsilon(5e-3).scale(0.6));
      CHECK(got.y == doctest::Approx(want.y).epsilon(5e-3).scale(0.6));
    }
    // At the centre it is the scene's one reported light.
    const Light centre = sh->lights_at({0, 0}).front();
    CHECK(centre.azimuth_deg == doctest::Approx(sh->lights.front().azimuth_deg).epsilon(1e-3));
    CHECK(centre.elevation_deg == doctest::Approx(sh->lights.front().elevation_deg).epsilon(1e-3));
  }
  // T1's light off the centre is radial and several times the centre's
  // (docs/LIGHT_PATH.md, "Off the centre"): the reason for this change.
  const Scene t1 = example_scene("T1C1");
  const ShadingEffect* sh = t1.find<ShadingEffect>();
  const double centre = std::hypot(sh->light_map->in_plane_fraction_at({0, 0}).x,
                                   sh->light_map->in_plane_fraction_at({0, 0}).y);
  const Vec2 left = sh->light_map->in_plane_fraction_at({-8, 0}), right = sh->light_map->in_plane_fraction_at({8, 0});
  CHECK(std::abs(left.x) > 3 * centre);
  CHECK(std::abs(right.x) > 3 * centre);
  CHECK(left.x * right.x < 0);  // toward the spot's centre from either side
}

TEST_CASE("light per point: the renderer's level is albedo (E_n - hx E_tx - hy E_ty) / unity at each point") {
  const Scene s = example_scene("T1C1");
  const TargetLayout layout = make_layout({});
  const ContactEffect* contact = s.find<ContactEffect>();
  const ShadingEffect* sh = s.find<ShadingEffect>();
  REQUIRE(contact);
  const ReliefField relief(layout, contact->sigma_mm, contact->depth_fraction * layout.relief_height_mm);
  const TargetRadiance radiance(s, layout);
  const LightPathModel model(s.light_path->options);
  const MembraneMapping mapping = mapping_of(s);
  const Vec2 centre{0.5 * layout.width_mm, 0.5 * layout.height_mm};
  int on_slopes = 0;
  // The edges of every element's first bar (both sides): a slope of either
  // sign across x or y, all over the target.
  for (const ElementLayout& e : layout.elements) {
    const auto& b = e.bars_mm.front();
    const bool vertical = e.orientation == BarOrientation::vertical_bars;
    for (const double side : {0.0, 1.0}) {
      const Vec2 p = vertical ? Vec2{b.x0 + side * (b.x1 - b.x0), 0.5 * (b.y0 + b.y1)}
                              : Vec2{0.5 * (b.x0 + b.x1), b.y0 + side * (b.y1 - b.y0)};
      const double d = 1e-4;
      const Vec2 quad[4] = {p + Vec2{-d, -d}, p + Vec2{d, -d}, p + Vec2{d, d}, p + Vec2{-d, d}};
      const ReliefField::Sample h = relief.at(p);
      const IrradianceVector ev = model.at(mapping.sensor_from_target_offset(p - centre));
      const Vec2 et = mapping.target_from_sensor_vector({ev.x_w_per_mm2, ev.y_w_per_mm2});
      const double want = sh->albedo *
                          (ev.normal_w_per_mm2 - h.slope_x * et.x - h.slope_y * et.y) /
                          s.light_path->unity_irradiance_w_per_mm2;
      CAPTURE(p.x);
      CAPTURE(p.y);
      // The illumination grid (1e-4) and the map's table (2e-3) interpolate.
      CHECK(radiance.over_footprint(quad) == doctest::Approx(want).epsilon(3e-3));
      on_slopes += std::abs(h.slope_x) + std::abs(h.slope_y) > 0.1;
    }
  }
  CHECK(on_slopes > 20);
}

TEST_CASE("light per point: the truth's CNR uses the shading gain over each element") {
  const CameraModel camera = CameraModel::load(kExamples / "cameras/wide_angle.cameramodel");
  const TargetLayout layout = make_layout({});
  const Scene per_point = example_scene("T1C1");
  Scene centre_only = per_point;  // the previous contract: the centre's light everywhere
  for (Effect& e : centre_only.effects)
    if (auto* sh = std::get_if<ShadingEffect>(&e)) sh->light_map.reset();
  const Truth a = compute_truth(per_point, layout, camera), b = compute_truth(centre_only, layout, camera);
  const LightPathModel model(per_point.light_path->options);
  const MembraneMapping mapping = mapping_of(per_point);
  const Vec2 centre{0.5 * layout.width_mm, 0.5 * layout.height_mm};
  const Vec2 t0 = model_fraction(model, mapping, {0, 0});
  REQUIRE(a.elements.size() == layout.elements.size());
  int compared = 0;
  for (size_t i = 0; i < a.elements.size(); ++i) {
    if (!a.elements[i].cnr || !b.elements[i].cnr) continue;
    const bool vertical = a.elements[i].orientation == BarOrientation::vertical_bars;
    const Vec2 c = layout.elements[i].extent_mm().center_mm() - centre;
    // Same ground (w l_z = 1 everywhere), same noise: the CNR scales with
    // the gain along the element's axis, the RMS of |t_u| E_n over the
    // triplet's width (detectability.h, rms_step_over_triplet) against
    // |t_u| at the centre times the RMS of E_n (3-point Gauss-Legendre, as
    // the truth; u along x across vertical bars). Compared in units of t:
    // the map interpolates t to ~2e-3.
    const double half_mm = triplet_half_width_mm(a.elements[i].lp_per_mm);
    double step_sq = 0, level_sq = 0;
    for (const auto& [x, w] : {std::pair{-std::sqrt(0.6), 5.0 / 18}, {0.0, 8.0 / 18}, {std::sqrt(0.6), 5.0 / 18}}) {
      const Vec2 p = c + (vertical ? Vec2{x * half_mm, 0} : Vec2{0, x * half_mm});
      const Vec2 t = model_fraction(model, mapping, p);
      const double e_n = model.at(mapping.sensor_from_target_offset(p)).normal_w_per_mm2;
      step_sq += w * std::pow((vertical ? t.x : t.y) * e_n, 2);
      level_sq += w * e_n * e_n;
    }
    const double gain_here = *a.elements[i].cnr / *b.elements[i].cnr * std::abs(vertical ? t0.x : t0.y);
    CAPTURE(i);
    CHECK(gain_here == doctest::Approx(std::sqrt(step_sq / level_sq)).epsilon(1e-2).scale(0.5));
    CHECK(a.elements[i].m == doctest::Approx(b.elements[i].m));  // m is the transfer, light-free
    ++compared;
  }
  CHECK(compared > 40);
}
