#include "tactres/simulate/effects/light_path.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <optional>
#include <random>
#include <string>
#include <tuple>

#include <doctest/doctest.h>
#include <nlohmann/json.hpp>

#include "tactres/simulate/effects/illumination.h"
#include "tactres/simulate/scene.h"

using namespace tactres;
using Type = LightPathOptions::Type;
using Aperture = LightPathOptions::Aperture;

namespace {

constexpr double kPi = std::numbers::pi;

// The example scenes' light path (docs/LIGHT_PATH.md): two 20 mW LEDs on one
// side of the lens, opal diffuser, a 36 x 36 x 4 mm silicone slab.
LightPathOptions study(Type type, Aperture aperture, double w, double h) {
  LightPathOptions o;
  o.type = type;
  o.aperture = aperture;
  o.aperture_width_mm = w;
  o.aperture_height_mm = h;
  o.diffuser_height_mm = type == Type::T1 ? 18.0 : 10.0;
  o.leds = {LedSource{{9.0, -3.0}, 0.02}, LedSource{{9.0, 3.0}, 0.02}};
  o.membrane_height_mm = 26.0;
  return o;
}

// One LED on the axis under a small disc: the diffuser's radiance is uniform
// over the disc to 1e-3.
LightPathOptions small_disc(double diameter_mm, double n) {
  LightPathOptions o = study(Type::T1, Aperture::circle, diameter_mm, diameter_mm);
  o.leds = {LedSource{{0.0, 0.0}, 0.02}};
  o.refractive_index = n;
  return o;
}

double on_axis_radiance(const LightPathOptions& o) {
  const double h = o.diffuser_height_mm, m = o.led_lambertian_order;
  return o.diffuser_transmittance * o.leds[0].flux_w * (m + 1) / (2 * kPi * h * h) / kPi;
}

// Composite 4-point Gauss-Legendre over [a, b].
template <class F>
double integrate(F f, double a, double b, int panels) {
  static const double x[4] = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563, 0.8611363115940526};
  static const double w[4] = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461, 0.3478548451374538};
  double sum = 0.0;
  const double h = (b - a) / panels;
  for (int p = 0; p < panels; ++p)
    for (int k = 0; k < 4; ++k) sum += 0.5 * h * w[k] * f(a + (p + 0.5) * h + 0.5 * h * x[k]);
  return sum;
}

}  // namespace

TEST_CASE("light_path: Fresnel transmittance at normal and grazing incidence") {
  const double n = 1.41;
  CHECK(light_path_detail::fresnel_transmittance(0.0, n) ==
        doctest::Approx(1.0 - std::pow((n - 1) / (n + 1), 2)).epsilon(1e-12));
  CHECK(light_path_detail::fresnel_transmittance(0.5 * kPi - 1e-6, n) < 1e-4);
  CHECK(light_path_detail::fresnel_transmittance(1.0, 1.0) == doctest::Approx(1.0));
}

TEST_CASE("light_path: a small Lambertian disc's on-axis irradiance follows the closed form") {
  // E = pi L a^2 / (a^2 + d^2) for a disc of radius a at distance d. With
  // n = 1 the slab is only distance (d = gap + t); the same disc at two
  // distances checks the inverse-square fall-off.
  for (const double membrane : {26.0, 40.0}) {
    LightPathOptions o = small_disc(1.0, 1.0);
    o.membrane_height_mm = membrane;
    const LightPathModel model(o);
    const double d = membrane - o.diffuser_height_mm, a = 0.5;
    const double expected = kPi * on_axis_radiance(o) * a * a / (a * a + d * d);
    CAPTURE(membrane);
    CHECK(model.at({0, 0}).normal_w_per_mm2 == doctest::Approx(expected).epsilon(2e-3));
    CHECK(model.at({0, 0}).in_plane_w_per_mm2() < 1e-9 * expected);
  }
  // The flux through the disc: a Lambertian LED on the axis sends the share
  // sin^2(alpha) = a^2 / (a^2 + H^2) through a coaxial disc.
  const LightPathOptions o = small_disc(1.0, 1.0);
  const double h = o.diffuser_height_mm;
  CHECK(LightPathModel(o).aperture_flux_w() ==
        doctest::Approx(o.diffuser_transmittance * 0.02 * 0.25 / (0.25 + h * h)).epsilon(2e-3));
}

TEST_CASE("light_path: the slab acts as its reduced thickness t / n, less the Fresnel loss") {
  const LightPathOptions o = small_disc(1.0, 1.41);
  const double gap = o.membrane_height_mm - o.elastomer_thickness_mm - o.diffuser_height_mm;
  const double d = gap + o.elastomer_thickness_mm / o.refractive_index, a = 0.5;
  const double expected = light_path_detail::fresnel_transmittance(0, 1.41) * kPi * on_axis_radiance(o) * a * a /
                          (a * a + d * d);
  CHECK(LightPathModel(o).at({0, 0}).normal_w_per_mm2 == doctest::Approx(expected).epsilon(3e-3));
  // Without refraction (n = 1) the same disc is farther away: less light.
  CHECK(LightPathModel(small_disc(1.0, 1.0)).at({0, 0}).normal_w_per_mm2 < 0.95 * expected);
}

TEST_CASE("light_path: a small disc seen off the axis: the light comes along the refracted ray") {
  // A point-like source at plan distance rho: E_tx / E_n = tan(theta') with
  // theta' the ray's angle inside the slab, rho = t tan(theta') + g tan(theta),
  // sin(theta) = n sin(theta') (found here by bisection). n = 1: rho / d.
  for (const double n : {1.0, 1.41}) {
    const LightPathOptions o = small_disc(1.0, n);
    const double t = o.elastomer_thickness_mm, g = o.membrane_height_mm - t - o.diffuser_height_mm, rho = 6.0;
    double lo = 0, hi = std::asin(1 / n) - 1e-12;
    for (int k = 0; k < 200; ++k) {
      const double mid = 0.5 * (lo + hi), th = std::asin(n * std::sin(mid));
      (t * std::tan(mid) + g * std::tan(th) < rho ? lo : hi) = mid;
    }
    const IrradianceVector e = LightPathModel(o).at({-rho, 0});  // the source is at +x
    CAPTURE(n);
    CHECK(e.x_w_per_mm2 / e.normal_w_per_mm2 == doctest::Approx(std::tan(lo)).epsilon(1e-2));
    CHECK(std::abs(e.y_w_per_mm2) < 1e-9 * e.normal_w_per_mm2);
  }
}

TEST_CASE("light_path: T1 conserves energy: the membrane receives the aperture's flux") {
  // n = 1: the flux reaching a membrane disc of radius R from a Lambertian
  // disc of radius a at distance d is the disc-to-disc configuration factor
  // (Howell, C-41): F = 2 (R2/R1)^2 / (X + sqrt(X^2 - 4 (R2/R1)^2)),
  // R_i = r_i / d, X = 1 + (1 + R2^2) / R1^2 (written without cancellation).
  LightPathOptions o = small_disc(1.0, 1.0);
  o.elastomer_side_mm = 400;
  const LightPathModel model(o);
  const double d = o.membrane_height_mm - o.diffuser_height_mm, a = 0.5, big_r = 150;
  const double r1 = a / d, r2 = big_r / d, q = (r2 / r1) * (r2 / r1);
  const double x = 1 + (1 + r2 * r2) / (r1 * r1);
  const double share = 2 * q / (x + std::sqrt(x * x - 4 * q));
  const double received =
      integrate([&](double rho) { return 2 * kPi * rho * model.at({rho, 0}).normal_w_per_mm2; }, 0, big_r, 600);
  CHECK(received == doctest::Approx(model.aperture_flux_w() * share).epsilon(2e-3));
  CHECK(share > 0.99);  // the check is about the whole flux, not a corner of it
}

TEST_CASE("light_path: a centred circle under symmetric LEDs gives no in-plane light at the centre") {
  for (const Type type : {Type::T1, Type::T2}) {
    LightPathOptions o = study(type, Aperture::circle, 15, 15);
    o.leds = {LedSource{{9, 0}, 0.02}, LedSource{{-9, 0}, 0.02}, LedSource{{0, 9}, 0.02}, LedSource{{0, -9}, 0.02}};
    const LightPathModel model(o);
    const IrradianceVector e = model.at({0, 0});
    CAPTURE(std::string(to_string(type)));
    CHECK(e.normal_w_per_mm2 > 0);
    CHECK(e.in_plane_w_per_mm2() < 1e-9 * e.normal_w_per_mm2);
    // Off the axis the light leans: toward the centre of the aperture in T1
    // (it is overhead), toward the nearer rim in T2.
    const IrradianceVector off = model.at({5, 0});
    if (type == Type::T1) CHECK(off.x_w_per_mm2 < -0.05 * off.normal_w_per_mm2);
    else CHECK(off.x_w_per_mm2 > 0.05 * off.normal_w_per_mm2);
  }
}

TEST_CASE("light_path: LEDs on one side tilt the light toward them") {
  for (const Type type : {Type::T1, Type::T2}) {
    const IrradianceVector e = LightPathModel(study(type, Aperture::circle, 15, 15)).at({0, 0});
    CAPTURE(std::string(to_string(type)));
    CHECK(e.x_w_per_mm2 > 0.01 * e.normal_w_per_mm2);                    // +x: the LEDs' side
    CHECK(std::abs(e.y_w_per_mm2) < 1e-9 * e.normal_w_per_mm2);          // symmetric in y
  }
}

TEST_CASE("light_path: guided light is grazing; T2 is more directional than T1 but dimmer") {
  // One rim side alone (a long edge 10 mm away): every ray rises at most
  // atan(2 t / a) above the membrane, so the in-plane component dominates.
  const light_path_detail::SlabOptics slab{4.0, 1.41, 100.0};
  IrradianceVector one_side;
  for (double s = -500; s < 500; s += 0.5)
    light_path_detail::add_edge_element(slab, {0, 0}, {-10, s + 0.25}, {1, 0}, 0.5, 1e-3, one_side);
  CHECK(one_side.in_plane_w_per_mm2() > 2 * one_side.normal_w_per_mm2);
  CHECK(one_side.elevation_deg() < std::atan(8.0 / 10.0) * 180 / kPi);
  // The whole rim: the four sides' in-plane parts largely cancel at the
  // centre, the normal parts add; what is left leans toward the brighter
  // rim (the LEDs' side). Still far more oblique than T1's overhead light,
  // which reaches the membrane ~10 times brighter.
  for (const auto& [ap, w, h] : {std::tuple{Aperture::circle, 15.0, 15.0}, std::tuple{Aperture::rectangle, 15.0, 33.0}}) {
    const IrradianceVector t2 = LightPathModel(study(Type::T2, ap, w, h)).at({0, 0});
    const IrradianceVector t1 = LightPathModel(study(Type::T1, ap, w, h)).at({0, 0});
    CAPTURE(h);
    CHECK(t2.in_plane_w_per_mm2() / t2.normal_w_per_mm2 > 2 * t1.in_plane_w_per_mm2() / t1.normal_w_per_mm2);
    CHECK(t2.x_w_per_mm2 > 0);
    CHECK(t1.normal_w_per_mm2 > 4 * t2.normal_w_per_mm2);
  }
}

TEST_CASE("light_path: more aperture area, more light") {
  const std::tuple<Aperture, double, double> designs[] = {{Aperture::circle, 15, 15},
                                                           {Aperture::square, 15, 15},
                                                           {Aperture::rectangle, 15, 24},
                                                           {Aperture::rectangle, 15, 33}};
  for (const Type type : {Type::T1, Type::T2}) {
    double last_flux = 0, last_normal = 0;
    for (const auto& [ap, w, h] : designs) {
      const LightPathModel model(study(type, ap, w, h));
      CAPTURE(std::string(to_string(type)));
      CAPTURE(h);
      CHECK(model.aperture_flux_w() > last_flux);
      CHECK(model.at({0, 0}).normal_w_per_mm2 > last_normal);
      last_flux = model.aperture_flux_w();
      last_normal = model.at({0, 0}).normal_w_per_mm2;
    }
  }
}

TEST_CASE("light_path: a geometry that would take minutes to integrate is refused") {
  LightPathOptions o = study(Type::T1, Aperture::rectangle, 200, 200);
  o.elastomer_side_mm = 500;
  o.diffuser_height_mm = 21.9;  // 0.1 mm below the slab: a tiny kernel under a huge window
  CHECK_THROWS_WITH_AS(o.validate(), doctest::Contains("kernel evaluations"), std::invalid_argument);
  CHECK_NOTHROW(study(Type::T1, Aperture::rectangle, 15, 33).validate());
  CHECK_NOTHROW(study(Type::T2, Aperture::rectangle, 15, 33).validate());
}

TEST_CASE("light_path: T2's rim receives edge_coupling times the aperture's flux") {
  LightPathOptions o = study(Type::T2, Aperture::rectangle, 15, 33);
  o.edge_coupling = 0.37;
  const LightPathModel model(o);
  CHECK(model.rim_flux_w() == doctest::Approx(0.37 * model.aperture_flux_w()).epsilon(1e-9));
  CHECK(LightPathModel(study(Type::T1, Aperture::circle, 15, 15)).rim_flux_w() == 0.0);
}

TEST_CASE("light_path: an edge strip's guided irradiance matches the closed form (n = 1)") {
  // n = 1, no attenuation: a vertical Lambertian strip of height t at plan
  // distance a, infinitely long, seen from a point of the top face:
  // E_n = pi L / 2 (1 - a / sqrt(a^2 + t^2)), E_toward = pi L / 2 t / sqrt(a^2 + t^2).
  const light_path_detail::SlabOptics slab{4.0, 1.0, 1e9};
  const double a = 5.0, t = 4.0, radiance = 1e-3, len = 0.5;
  IrradianceVector e;
  for (double s = -2000; s < 2000; s += len)
    light_path_detail::add_edge_element(slab, {0, 0}, {-a, s + 0.5 * len}, {1, 0}, len, radiance, e);
  CHECK(e.normal_w_per_mm2 == doctest::Approx(0.5 * kPi * radiance * (1 - a / std::hypot(a, t))).epsilon(1e-3));
  CHECK(-e.x_w_per_mm2 == doctest::Approx(0.5 * kPi * radiance * t / std::hypot(a, t)).epsilon(1e-3));
  CHECK(std::abs(e.y_w_per_mm2) < 1e-9 * e.normal_w_per_mm2);
  // Attenuation only takes light away; a real index adds the total
  // reflection path but confines the light to the refraction cone.
  IrradianceVector lossy;
  const light_path_detail::SlabOptics absorbing{4.0, 1.0, 20.0};
  for (double s = -2000; s < 2000; s += len)
    light_path_detail::add_edge_element(absorbing, {0, 0}, {-a, s + 0.5 * len}, {1, 0}, len, radiance, lossy);
  CHECK(lossy.normal_w_per_mm2 < 0.9 * e.normal_w_per_mm2);
  CHECK(lossy.normal_w_per_mm2 > 0.5 * e.normal_w_per_mm2);
}

TEST_CASE("light_path: the map reproduces the model and continues smoothly beyond the membrane") {
  for (const Type type : {Type::T1, Type::T2}) {
    const LightPathOptions o = study(type, Aperture::rectangle, 15, 33);
    const LightPathModel model(o);
    MembraneMapping mapping;
    mapping.target_center_sensor_mm = {0.5, -0.3};
    mapping.roll_deg = 3;
    mapping.mirrored = true;
    const LightPathMap map(model, mapping);
    // Where the bars are (within 10 mm of the axis) and out to the table's
    // knee (14 mm; T2's field steepens toward the rim).
    std::mt19937 rng(7);
    for (const auto& [reach, tolerance] : {std::pair{10.0, 2e-3}, std::pair{14.0, 1e-2}}) {
      std::uniform_real_distribution<double> u(-reach, reach);
      double worst = 0;
      for (int k = 0; k < 200; ++k) {
        const Vec2 s{u(rng), u(rng)};
        worst = std::max(worst, std::abs(map.at_sensor(s) / model.at(s).normal_w_per_mm2 - 1));
      }
      CAPTURE(std::string(to_string(type)));
      CAPTURE(reach);
      CHECK(worst < tolerance);
    }
    // Target offsets go through the pose's roll and mirror.
    const Vec2 off{4.0, 2.0};
    CHECK(map.irradiance_at(off) == doctest::Approx(map.at_sensor(mapping.sensor_from_target_offset(off))));
    // Far outside the slab: finite, positive, near the table's edge value.
    const double far = map.at_sensor({200, 0}), edge = map.at_sensor({map.table_half_width_mm(), 0});
    CHECK(far > 0);
    CHECK(far == doctest::Approx(edge).epsilon(1e-3));
  }
}

TEST_CASE("light_path: the mapping matches the pose's rotation (through the gel, rolled)") {
  const ViewPose v{.view = "through_gel", .distance_mm = 26, .roll_deg = 3, .offset_mm = {1.5, -2.0}};
  const double w = 20, h = 18;
  const auto rt = rt_from_view(v, w, h);
  // Rodrigues: camera point of target point (w/2 + o.x, h/2 + o.y, 0).
  auto camera_of = [&](Vec2 p) {
    const double th = std::sqrt(rt[0] * rt[0] + rt[1] * rt[1] + rt[2] * rt[2]);
    const double k[3] = {rt[0] / th, rt[1] / th, rt[2] / th}, x[3] = {p.x, p.y, 0};
    const double kx[3] = {k[1] * x[2] - k[2] * x[1], k[2] * x[0] - k[0] * x[2], k[0] * x[1] - k[1] * x[0]};
    const double kdx = k[0] * x[0] + k[1] * x[1] + k[2] * x[2];
    double out[3];
    for (int i = 0; i < 3; ++i)
      out[i] = x[i] * std::cos(th) + kx[i] * std::sin(th) + k[i] * kdx * (1 - std::cos(th)) + rt[3 + i];
    return Vec2{out[0], out[1]};
  };
  MembraneMapping m{{1.5, -2.0}, 3.0, true};
  for (const Vec2 o : {Vec2{0, 0}, Vec2{5, 0}, Vec2{0, 5}, Vec2{-3, 7}}) {
    const Vec2 expected = camera_of({0.5 * w + o.x, 0.5 * h + o.y});
    const Vec2 got = m.sensor_from_target_offset(o);
    CHECK(got.x == doctest::Approx(expected.x).epsilon(1e-9));
    CHECK(got.y == doctest::Approx(expected.y).epsilon(1e-9));
  }
  // A sensor-frame vector back to the target frame: the inverse rotation.
  const Vec2 v_t = m.target_from_sensor_vector({1, 0});
  const Vec2 back = m.sensor_from_target_offset(v_t) - m.target_center_sensor_mm;
  CHECK(back.x == doctest::Approx(1.0));
  CHECK(back.y == doctest::Approx(0.0).epsilon(1e-12));
}

TEST_CASE("light_path: the renderer's illumination grid converges on the mapped field") {
  for (const Type type : {Type::T1, Type::T2}) {
    const LightPathResult r =
        resolve_light_path(study(type, Aperture::circle, 15, 15), MembraneMapping{{0, 0}, 3, true}, 1e-5);
    IlluminationOptions o;
    o.shape = IlluminationOptions::mapped;
    o.map = r.map;
    o.distance_mm = r.length_scale_mm;
    o.aperture_center_mm = {10, 10};
    o.gain = r.illumination_gain;
    const auto t0 = std::chrono::steady_clock::now();
    const IlluminationField field(o, RectMm{-10, -10, 30, 30});
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    CAPTURE(std::string(to_string(type)));
    MESSAGE(std::string(to_string(type)) << ": grid " << field.grid_columns() << " x " << field.grid_rows() << ", "
                            << seconds * 1e3 << " ms, error " << field.measured_grid_error());
    CHECK(field.measured_grid_error() < 1e-4);
    CHECK(field.relative_irradiance({10, 10}) == doctest::Approx(r.illumination_gain).epsilon(1e-4));
    CHECK(field.relative_irradiance({14, 8}) ==
          doctest::Approx(r.illumination_gain * r.map->irradiance_at({4, -2}) / r.map->irradiance_at({0, 0}))
              .epsilon(2e-4));
  }
}

namespace {

nlohmann::json relief_scene(nlohmann::json light_path) {
  return {{"schema", "tactres.scene/1"},
          {"design", "T1C1"},
          {"camera", "cam.cameramodel"},
          {"target", {{"kind", "relief"}}},
          {"pose", {{"view", "through_gel"}, {"distance_mm", 26.0}, {"roll_deg", 3.0}}},
          {"effects",
           {{{"effect", "contact"}, {"sigma_mm", 0.035}, {"depth_fraction", 0.8}}, light_path,
            {{"effect", "blur"}, {"psf", "gaussian"}, {"sigma_px", 1.1}}}}};
}

nlohmann::json t1c1() {
  return {{"effect", "light_path"},
          {"type", "T1"},
          {"aperture", "circle"},
          {"aperture_mm", {15, 15}},
          {"diffuser_height_mm", 18},
          {"leds", {{{"position_mm", {9, -3}}, {"flux_mw", 20}}, {{"position_mm", {9, 3}}, {"flux_mw", 20}}}},
          {"elastomer", {{"side_mm", 36}, {"thickness_mm", 4}, {"refractive_index", 1.41}}},
          {"albedo", 0.9},
          {"unity_irradiance_w_per_m2", 10}};
}

std::string refusal(const nlohmann::json& scene) {
  try {
    scene_from_json(scene, "scene.json");
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(accepted)";
}

}  // namespace

TEST_CASE("light_path scene: resolves into one shading light and a mapped illumination field") {
  const Scene s = scene_from_json(relief_scene(t1c1()), "scene.json");
  REQUIRE(s.effects.size() == 4);
  CHECK(std::string(effect_name(s.effects[1])) == "shading");
  CHECK(std::string(effect_name(s.effects[2])) == "illumination");
  const ShadingEffect* sh = s.find<ShadingEffect>();
  const IlluminationOptions* ill = s.find<IlluminationOptions>();
  REQUIRE(sh);
  REQUIRE(ill);
  REQUIRE(s.light_path);
  CHECK(sh->model == ShadingEffect::Model::lambert_linearised);
  CHECK(sh->albedo == 0.9);
  REQUIRE(sh->lights.size() == 1);
  const Light& l = sh->lights[0];
  // Normalised so that w sin(elevation) = 1: a flat membrane reads albedo x E.
  CHECK(l.weight * std::sin(l.elevation_deg * kPi / 180) == doctest::Approx(1.0));
  CHECK(ill->shape == IlluminationOptions::mapped);
  CHECK(std::isnan(ill->aperture_center_mm.x));
  CHECK(ill->gain == doctest::Approx(s.light_path->at_target_center.normal_w_per_mm2 / 1e-5));
  // Through the gel the sensor's +x (the LEDs' side) is the target's -x
  // (3 degrees of roll aside).
  CHECK(std::abs(std::abs(l.azimuth_deg) - 177.0) < 1.0);
  CHECK(s.light_path->build_seconds < 1.0);
}

TEST_CASE("light_path scene: bad values and combinations are refused, naming the field") {
  auto with = [](const char* key, nlohmann::json value) {
    nlohmann::json lp = t1c1();
    lp[key] = std::move(value);
    return relief_scene(lp);
  };
  CHECK(refusal(with("diffuser_height_mm", -1)).find("diffuser_height_mm") != std::string::npos);
  CHECK(refusal(with("colour", "white")).find("colour") != std::string::npos);
  CHECK(refusal(with("type", "T3")).find("type") != std::string::npos);
  CHECK(refusal(with("aperture", "square")).find("(accepted)") != std::string::npos);
  CHECK(refusal(with("aperture_mm", {15, 20})).find("equal sides") != std::string::npos);
  CHECK(refusal(with("edge_coupling", 0.5)).find("T2 only") != std::string::npos);
  CHECK(refusal(with("unity_irradiance_w_per_m2", 1e-8)).find("factor 1000") != std::string::npos);
  CHECK(refusal(with("leds", {{{"position_mm", {9, 0}}, {"flux_mw", 0}}})).find("leds[0].flux_mw") !=
        std::string::npos);
  CHECK(refusal(with("leds", nlohmann::json::array())).find("leds") != std::string::npos);
  CHECK(refusal(with("elastomer", {{"thickness_mm", 4}, {"shore", 20}})).find("shore") != std::string::npos);
  CHECK(refusal(with("elastomer", {{"refractive_index", 3}})).find("refractive_index") != std::string::npos);
  // The diffuser inside the slab: no air gap for T1's light to cross.
  CHECK(refusal(with("diffuser_height_mm", 23)).find("below the elastomer") != std::string::npos);
  nlohmann::json missing = t1c1();
  missing.erase("unity_irradiance_w_per_m2");
  CHECK(refusal(relief_scene(missing)).find("unity_irradiance_w_per_m2") != std::string::npos);
  // T2: the aperture must fit inside the rim.
  nlohmann::json t2 = t1c1();
  t2["type"] = "T2";
  t2["diffuser_height_mm"] = 10;
  t2["aperture"] = "rectangle";
  t2["aperture_mm"] = {15, 40};
  CHECK(refusal(relief_scene(t2)).find("inside the elastomer's rim") != std::string::npos);

  // Combinations.
  nlohmann::json both = relief_scene(t1c1());
  both["effects"].insert(both["effects"].begin() + 1, nlohmann::json{{"effect", "shading"}});
  CHECK(refusal(both).find("not both") != std::string::npos);
  nlohmann::json with_ill = relief_scene(t1c1());
  with_ill["effects"].insert(with_ill["effects"].begin() + 2,
                             nlohmann::json{{"effect", "illumination"}, {"aperture_mm", {15, 15}}, {"distance_mm", 8}});
  CHECK(refusal(with_ill).find("not both") != std::string::npos);
  nlohmann::json albedo = relief_scene(t1c1());
  albedo["target"] = {{"kind", "albedo"}};
  albedo["effects"].erase(0);
  CHECK(refusal(albedo).find("relief") != std::string::npos);
  nlohmann::json no_contact = relief_scene(t1c1());
  no_contact["effects"].erase(0);
  CHECK(refusal(no_contact).find("contact") != std::string::npos);
  nlohmann::json rt = relief_scene(t1c1());
  rt["pose"] = {{"rt_camera_from_target", {0, 3.14159, 0, 10, -10, 26}}};
  CHECK(refusal(rt).find("view form") != std::string::npos);
  nlohmann::json off = relief_scene(t1c1());
  off["pose"]["offset_mm"] = {20, 0};
  CHECK(refusal(off).find("on the membrane") != std::string::npos);
}

TEST_CASE("light_path scene: the eight example designs load fast and share one sensor") {
  const std::filesystem::path dir = std::filesystem::path(TACTRES_SOURCE_DIR) / "examples/scenes";
  std::optional<nlohmann::json> sensor;
  std::optional<double> exposure;
  for (const char* design : {"T1C1", "T1C2", "T1C3", "T1C4", "T2C1", "T2C2", "T2C3", "T2C4"}) {
    // The best of three loads: the budget is the model's cost, not the
    // machine's other load.
    double ms = 1e9;
    std::optional<Scene> loaded;
    for (int k = 0; k < 3; ++k) {
      const auto t0 = std::chrono::steady_clock::now();
      loaded = read_scene_file(dir / (std::string(design) + ".json"));
      ms = std::min(ms, 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    const Scene& s = *loaded;
    CAPTURE(std::string(design));
    REQUIRE(s.light_path);
    MESSAGE(std::string(design) << ": loaded in " << ms << " ms");
#ifdef NDEBUG
    CHECK(ms < 50.0);
#endif
    CHECK(s.light_path->options.type == (design[1] == '1' ? Type::T1 : Type::T2));
    // One exposure and one sensor for all eight (the seed aside).
    nlohmann::json j = nlohmann::json::parse(std::ifstream(dir / (std::string(design) + ".json")));
    nlohmann::json sens = j["effects"].back();
    REQUIRE(sens["effect"] == "sensor");
    sens.erase("seed");
    if (!sensor) sensor = sens;
    CHECK(sens == *sensor);
    if (!exposure) exposure = s.light_path->unity_irradiance_w_per_mm2;
    CHECK(s.light_path->unity_irradiance_w_per_mm2 == *exposure);
  }
}
