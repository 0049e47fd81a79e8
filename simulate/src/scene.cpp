#include "tactres/simulate/scene.h"

#include <cmath>
#include <numbers>
#include <stdexcept>

#include <ceres/rotation.h>
#include <fmt/format.h>
extern "C" {  // mrcal ships C headers without C++ guards
#include <mrcal/poseutils.h>
}
#include <nlohmann/json.hpp>

#include "tactres/simulate/effects/light_path.h"
#include "tactres/util/atomic_file.h"
#include "tactres/util/json_fields.h"
#include "tactres/targets/layout_json.h"

namespace tactres {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// Physical order of the pipeline: target plane, then optics, then sensor.
// "light_path" stands for shading + illumination (it resolves into both).
const std::vector<std::string> kEffectOrder = {"contact", "shading",    "illumination", "light_path",
                                               "blur",    "vignetting", "sensor"};

ContactEffect parse_contact(JsonFields& f) {
  ContactEffect e;
  e.sigma_mm = f.number("sigma_mm", e.sigma_mm, 1e-4, 5, "mm");
  e.depth_fraction = f.number("depth_fraction", e.depth_fraction, 1e-3, 1);
  return e;
}

ShadingEffect parse_shading(JsonFields& f) {
  ShadingEffect e;
  const std::string model = f.text("model", "lambert_linearised", {"lambert", "lambert_linearised"});
  e.model = model == "lambert" ? ShadingEffect::Model::lambert : ShadingEffect::Model::lambert_linearised;
  e.albedo = f.number("albedo", e.albedo, 1e-3, 1);
  e.ambient = f.number("ambient", e.ambient, 0, 1);
  if (const nlohmann::json* lights = f.raw_optional("lights")) {
    if (!lights->is_array() || lights->empty())
      throw std::invalid_argument(f.where() + ".lights must be a non-empty array of lights");
    e.lights.clear();
    for (size_t i = 0; i < lights->size(); ++i) {
      JsonFields l((*lights)[i], fmt::format("{}.lights[{}]", f.where(), i));
      Light light;
      light.azimuth_deg = l.number("azimuth_deg", 0.0, -360, 360, "deg");
      light.elevation_deg = l.number("elevation_deg", 45.0, 0.1, 90, "deg");
      light.weight = l.number("weight", 1.0, 1e-6, 1e6);
      l.finish();
      e.lights.push_back(light);
    }
  }
  return e;
}

IlluminationOptions parse_illumination(JsonFields& f) {
  IlluminationOptions e;
  const std::string shape = f.text("aperture", "circle", {"circle", "square", "rectangle"});
  e.shape = shape == "circle"   ? IlluminationOptions::Shape::circle
            : shape == "square" ? IlluminationOptions::Shape::square
                                : IlluminationOptions::Shape::rectangle;
  const auto size = f.numbers("aperture_mm", 2, 0.01, 1000, "mm");
  e.aperture_width_mm = size[0];
  e.aperture_height_mm = size[1];
  e.distance_mm = f.number("distance_mm", std::nullopt, 0.01, 1000, "mm");
  if (f.has("center_mm")) {
    const auto c = f.numbers("center_mm", 2, -1000, 1000, "mm");
    e.aperture_center_mm = {c[0], c[1]};
  } else {
    f.raw_optional("center_mm");
    e.aperture_center_mm = {std::nan(""), std::nan("")};  // resolved to the target centre
  }
  e.gain = f.number("gain", 1.0, 1e-3, 100);
  if (const nlohmann::json* spots = f.raw_optional("hot_spots")) {
    if (!spots->is_array()) throw std::invalid_argument(f.where() + ".hot_spots must be an array");
    for (size_t i = 0; i < spots->size(); ++i) {
      JsonFields s((*spots)[i], fmt::format("{}.hot_spots[{}]", f.where(), i));
      HotSpot h;
      const auto c = s.numbers("center_mm", 2, -1000, 1000, "mm");
      h.center_mm = {c[0], c[1]};
      h.sigma_mm = s.number("sigma_mm", std::nullopt, 1e-3, 1000, "mm");
      h.peak_gain = s.number("peak_gain", std::nullopt, 0, 100);
      s.finish();
      e.hot_spots.push_back(h);
    }
  }
  return e;
}

// The light_path effect (effects/light_path.h, docs/LIGHT_PATH.md), resolved
// here into the shading light and the illumination field the renderer and
// the truth already know: nothing downstream sees the light path itself.
struct ResolvedLightPath {
  ShadingEffect shading;
  IlluminationOptions illumination;
  LightPathResult result;
};

LightPathOptions parse_light_path_options(JsonFields& f) {
  LightPathOptions o;
  o.type = f.text("type", std::nullopt, {"T1", "T2"}) == "T1" ? LightPathOptions::Type::T1
                                                              : LightPathOptions::Type::T2;
  const std::string shape = f.text("aperture", std::nullopt, {"circle", "square", "rectangle"});
  o.aperture = shape == "circle"   ? LightPathOptions::Aperture::circle
               : shape == "square" ? LightPathOptions::Aperture::square
                                   : LightPathOptions::Aperture::rectangle;
  const auto size = f.numbers("aperture_mm", 2, 0.01, 200, "mm");
  if (o.aperture != LightPathOptions::Aperture::rectangle && size[0] != size[1])
    throw std::invalid_argument(fmt::format(
        "{}.aperture_mm: a {} aperture has equal sides ([{}, {}] given); use \"rectangle\" for [w, h]",
        f.where(), shape, size[0], size[1]));
  o.aperture_width_mm = size[0];
  o.aperture_height_mm = size[1];
  o.diffuser_height_mm = f.number("diffuser_height_mm", std::nullopt, 0.5, 500, "mm");
  o.diffuser_transmittance = f.number("diffuser_transmittance", o.diffuser_transmittance, 1e-3, 1);
  const nlohmann::json& leds = f.raw("leds");
  if (!leds.is_array() || leds.empty() || leds.size() > 64)
    throw std::invalid_argument(f.where() + ".leds must be an array of 1 to 64 LEDs");
  for (size_t i = 0; i < leds.size(); ++i) {
    JsonFields l(leds[i], fmt::format("{}.leds[{}]", f.where(), i));
    LedSource led;
    const auto pos = l.numbers("position_mm", 2, -500, 500, "mm");
    led.position_mm = {pos[0], pos[1]};
    led.flux_w = 1e-3 * l.number("flux_mw", std::nullopt, 1e-6, 1e4, "mW");
    l.finish();
    o.leds.push_back(led);
  }
  o.led_lambertian_order = f.number("led_lambertian_order", o.led_lambertian_order, 0.1, 100);
  if (const nlohmann::json* e = f.raw_optional("elastomer")) {
    JsonFields ef(*e, f.where() + ".elastomer");
    o.elastomer_side_mm = ef.number("side_mm", o.elastomer_side_mm, 2, 500, "mm");
    o.elastomer_thickness_mm = ef.number("thickness_mm", o.elastomer_thickness_mm, 0.1, 50, "mm");
    o.refractive_index = ef.number("refractive_index", o.refractive_index, 1, 2.5);
    o.attenuation_length_mm = ef.number("attenuation_length_mm", o.attenuation_length_mm, 1, 1e7, "mm");
    ef.finish();
  }
  if (o.type == LightPathOptions::Type::T2)
    o.edge_coupling = f.number("edge_coupling", o.edge_coupling, 1e-6, 1);
  else if (f.has("edge_coupling"))
    throw std::invalid_argument(f.where() +
                                ".edge_coupling applies to T2 only (T1 has no light guided through the edge)");
  return o;
}

ResolvedLightPath parse_light_path(JsonFields& f, const Scene& s) {
  if (!s.view_pose)
    throw std::invalid_argument(
        f.where() +
        ": light_path needs the pose in view form (view, distance_mm, roll_deg, offset_mm): distance_mm "
        "places the membrane above the CMOS, rt_camera_from_target cannot say where the light is");
  const ViewPose& v = *s.view_pose;
  ResolvedLightPath r;
  LightPathOptions o = parse_light_path_options(f);
  o.membrane_height_mm = v.distance_mm;
  // Linearised by default: the chain stays linear and the truth analytic.
  r.shading.model = f.text("shading_model", "lambert_linearised", {"lambert_linearised", "lambert"}) == "lambert"
                        ? ShadingEffect::Model::lambert
                        : ShadingEffect::Model::lambert_linearised;
  r.shading.albedo = f.number("albedo", 0.9, 1e-3, 1);
  r.shading.ambient = f.number("ambient", 0.0, 0, 1);
  const double unity_w_per_m2 = f.number("unity_irradiance_w_per_m2", std::nullopt, 1e-9, 1e9, "W/m^2");
  MembraneMapping mapping;
  mapping.target_center_sensor_mm = {v.offset_mm[0], v.offset_mm[1]};
  mapping.roll_deg = v.roll_deg;
  mapping.mirrored = v.view == "through_gel";
  try {
    r.result = resolve_light_path(o, mapping, 1e-6 * unity_w_per_m2);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(f.where() + ": " + e.what());
  }
  const LightPathResult& lp = r.result;
  if (!(lp.illumination_gain >= 1e-3 && lp.illumination_gain <= 1e3))
    throw std::invalid_argument(fmt::format(
        "{}: the membrane irradiance at the target centre is {:.3g} W/m^2, {:.3g} times "
        "unity_irradiance_w_per_m2 ({} W/m^2): set the exposure within a factor 1000 of the light",
        f.where(), 1e6 * lp.at_target_center.normal_w_per_mm2, lp.illumination_gain, unity_w_per_m2));
  r.shading.lights = {Light{lp.azimuth_deg, lp.elevation_deg, lp.weight}};
  r.shading.light_map = lp.map;
  r.illumination.shape = IlluminationOptions::mapped;
  r.illumination.map = lp.map;
  r.illumination.distance_mm = std::max(0.5, lp.length_scale_mm);
  r.illumination.aperture_center_mm = {std::nan(""), std::nan("")};  // resolved to the target centre
  r.illumination.gain = lp.illumination_gain;
  return r;
}

PsfOptions parse_blur(JsonFields& f) {
  PsfOptions e;
  const std::string kind = f.text("psf", std::nullopt, {"gaussian", "defocus_disc", "diffraction"});
  e.kind = psf_kind_from_string(kind);
  if (e.kind == PsfOptions::gaussian) e.sigma_px = f.number("sigma_px", std::nullopt, 0, 200, "px");
  if (e.kind == PsfOptions::defocus_disc)
    e.radius_px = f.number("radius_px", std::nullopt, 0, 200, "px");
  if (e.kind == PsfOptions::diffraction) {
    e.f_number = f.number("f_number", std::nullopt, 0.5, 128);
    e.wavelength_um = f.number("wavelength_um", 0.55, 0.2, 20, "um");
    e.pixel_pitch_um = f.number("pixel_pitch_um", std::nullopt, 0.3, 100, "um");
  }
  return e;
}

VignettingEffect parse_vignetting(JsonFields& f) {
  VignettingEffect e;
  e.exponent = f.number("exponent", e.exponent, 0, 8);
  return e;
}

SensorOptions parse_sensor(JsonFields& f) {
  SensorOptions e;
  e.bit_depth = f.integer("bit_depth", e.bit_depth, 8, 16);
  e.full_well_e = f.number("full_well_e", e.full_well_e, 1, 1e8, "e-");
  e.quantum_efficiency = f.number("quantum_efficiency", e.quantum_efficiency, 1e-3, 1);
  e.dark_signal_e = f.number("dark_signal_e", e.dark_signal_e, 0, 1e8, "e-");
  e.read_noise_e = f.number("read_noise_e", e.read_noise_e, 0, 1e5, "e-");
  e.photons_at_unity = f.number("photons_at_unity", e.photons_at_unity, 1e-3, 1e9, "photons");
  if (f.has("gain_dn_per_e")) e.gain_dn_per_e = f.number("gain_dn_per_e", std::nullopt, 1e-6, 1e3, "DN/e-");
  else f.raw_optional("gain_dn_per_e");
  e.seed = static_cast<std::uint64_t>(f.integer("seed", 1, 0, 2147483647));
  e.validate();
  return e;
}

// The effects list, in physical order; "light_path" resolves into shading
// and illumination here (it needs the pose and the target kind, read before).
void parse_effects(const nlohmann::json& effects, Scene& s) {
  if (!effects.is_array()) throw std::invalid_argument("scene.effects must be an array (may be empty)");
  int last_rank = -1;
  bool light_path = false, shading_or_illumination = false;
  for (size_t i = 0; i < effects.size(); ++i) {
    const std::string where = fmt::format("scene.effects[{}]", i);
    JsonFields f(effects[i], where);
    const std::string name = f.text("effect", std::nullopt, kEffectOrder);
    const int rank = static_cast<int>(std::find(kEffectOrder.begin(), kEffectOrder.end(), name) - kEffectOrder.begin());
    if (name == "light_path") light_path = true;
    if (name == "shading" || name == "illumination") shading_or_illumination = true;
    if (light_path && shading_or_illumination)
      throw std::invalid_argument(fmt::format(
          "{}: \"light_path\" resolves into the shading light and the illumination field; list either "
          "\"light_path\" or \"shading\"/\"illumination\", not both",
          where));
    if (rank <= last_rank)
      throw std::invalid_argument(fmt::format(
          "{}: \"{}\" is out of order or repeated: effects run in the physical order contact, "
          "shading, illumination (or light_path instead of both), blur, vignetting, sensor, each at most once",
          where, name));
    last_rank = rank;
    switch (rank) {
      case 0: s.effects.emplace_back(parse_contact(f)); break;
      case 1: s.effects.emplace_back(parse_shading(f)); break;
      case 2: s.effects.emplace_back(parse_illumination(f)); break;
      case 3: {
        if (s.target != TargetKind::relief)
          throw std::invalid_argument(where +
                                      ": light_path shades a relief pressed into the gel; set target.kind to "
                                      "\"relief\" (a printed target takes \"illumination\")");
        if (!s.find<ContactEffect>())
          throw std::invalid_argument(where +
                                      ": light_path needs a contact effect before it: a rigid relief step has no "
                                      "slope to shade, only the gel's smoothing creates one");
        ResolvedLightPath lp = parse_light_path(f, s);
        s.effects.emplace_back(std::move(lp.shading));
        s.effects.emplace_back(std::move(lp.illumination));
        s.light_path = std::move(lp.result);
        break;
      }
      case 4: {
        PsfOptions psf = parse_blur(f);
        psf.validate();
        s.effects.emplace_back(psf);
        break;
      }
      case 5: s.effects.emplace_back(parse_vignetting(f)); break;
      case 6: s.effects.emplace_back(parse_sensor(f)); break;
    }
    f.finish();
  }
}

}  // namespace

std::vector<Light> ShadingEffect::lights_at(Vec2 offset_mm) const {
  if (!light_map) return lights;
  const Vec2 t = light_map->in_plane_fraction_at(offset_mm);
  const double in_plane = std::hypot(t.x, t.y);
  // w cos(el) = |t| and w sin(el) = 1: the renderer's w l = (t_x, t_y, 1).
  return {Light{std::atan2(t.y, t.x) / kDeg, std::atan2(1.0, in_plane) / kDeg,
                std::hypot(1.0, in_plane)}};
}

const char* effect_name(const Effect& e) {
  // The variant's types; light_path is not one (it resolves into shading and
  // illumination).
  static const char* kNames[] = {"contact", "shading", "illumination", "blur", "vignetting", "sensor"};
  return kNames[e.index()];
}

std::array<double, 6> rt_from_view(const ViewPose& v, double W, double H) {
  // Camera frame: x right, y down, z along the optical axis (mrcal).
  auto rot = [](double ax, double ay, double az, double angle, double R[9]) {
    const double r[3] = {ax * angle, ay * angle, az * angle};
    mrcal_R_from_r(R, nullptr, r);
  };
  auto mul = [](const double A[9], const double B[9], double C[9]) {
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k)
        C[i * 3 + k] = A[i * 3] * B[k] + A[i * 3 + 1] * B[3 + k] + A[i * 3 + 2] * B[6 + k];
  };
  double view[9], roll[9], tilt[9], tmp[9], R[9];
  // Through the gel the camera looks at the target from behind: a half turn
  // about the target's y axis. The image is mirrored; the rotation is proper.
  rot(0, 1, 0, v.view == "through_gel" ? std::numbers::pi : 0.0, view);
  rot(0, 0, 1, v.roll_deg * kDeg, roll);
  rot(std::cos(v.tilt_axis_deg * kDeg), std::sin(v.tilt_axis_deg * kDeg), 0, v.tilt_deg * kDeg, tilt);
  mul(roll, view, tmp);
  mul(tilt, tmp, R);
  std::array<double, 6> rt{};
  // Not mrcal_r_from_R: it returns r = 0 for a rotation by exactly pi, which
  // is what a fronto-parallel through-gel view is. Ceres' conversion is
  // stable there.
  ceres::RotationMatrixToAngleAxis(ceres::RowMajorAdapter3x3(static_cast<const double*>(R)), rt.data());
  const double c[3] = {0.5 * W, 0.5 * H, 0};
  const double target_center_camera[3] = {v.offset_mm[0], v.offset_mm[1], v.distance_mm};
  for (int i = 0; i < 3; ++i)
    rt[3 + i] = target_center_camera[i] - (R[i * 3] * c[0] + R[i * 3 + 1] * c[1] + R[i * 3 + 2] * c[2]);
  return rt;
}

std::array<double, 6> Scene::rt_camera_from_target(const TargetLayout& layout) const {
  if (rt_explicit) return *rt_explicit;
  return rt_from_view(view_pose.value_or(ViewPose{}), layout.width_mm, layout.height_mm);
}

Scene scene_from_json(const nlohmann::json& j, const std::filesystem::path& source) {
  JsonFields top(j, "scene");
  const std::string schema = top.text("schema", std::nullopt);
  if (schema != kSceneSchema)
    throw std::invalid_argument(fmt::format("scene.schema is \"{}\", expected \"{}\"", schema, kSceneSchema));
  Scene s;
  s.source = source;
  const std::filesystem::path base = source.parent_path();
  s.design = top.text("design", std::nullopt);
  if (s.design.empty() || s.design.find_first_of("/\\ ") != std::string::npos)
    throw std::invalid_argument("scene.design must be a short label without spaces or slashes, e.g. \"T1C1\"");
  s.description = top.text("description", std::string());
  if (top.has("layout")) s.layout_path = base / top.text("layout", std::nullopt);
  else top.raw_optional("layout");
  s.camera_path = base / top.text("camera", std::nullopt);

  {
    JsonFields t(top.raw("target"), "scene.target");
    const std::string kind = t.text("kind", std::nullopt, {"albedo", "relief"});
    s.target = kind == "albedo" ? TargetKind::albedo : TargetKind::relief;
    if (s.target == TargetKind::albedo) {
      s.ink_reflectance = t.number("ink_reflectance", s.ink_reflectance, 0, 1);
      s.ground_reflectance = t.number("ground_reflectance", s.ground_reflectance, 0, 1);
      if (s.ink_reflectance == s.ground_reflectance)
        throw std::invalid_argument("scene.target: ink and ground reflectance are equal: the target is invisible");
    }
    t.finish();
  }

  {
    JsonFields p(top.raw("pose"), "scene.pose");
    if (p.has("rt_camera_from_target")) {
      const auto rt = p.numbers("rt_camera_from_target", 6, -1e4, 1e4, "(rad, mm)");
      s.rt_explicit = std::array<double, 6>{rt[0], rt[1], rt[2], rt[3], rt[4], rt[5]};
    } else {
      p.raw_optional("rt_camera_from_target");
      ViewPose v;
      v.view = p.text("view", v.view, {"direct", "through_gel"});
      v.distance_mm = p.number("distance_mm", v.distance_mm, 1, 1e4, "mm");
      v.roll_deg = p.number("roll_deg", 0.0, -360, 360, "deg");
      v.tilt_deg = p.number("tilt_deg", 0.0, -80, 80, "deg");
      v.tilt_axis_deg = p.number("tilt_axis_deg", 0.0, -360, 360, "deg");
      if (p.has("offset_mm")) {
        const auto o = p.numbers("offset_mm", 2, -1e4, 1e4, "mm");
        v.offset_mm = {o[0], o[1]};
      } else {
        p.raw_optional("offset_mm");
      }
      s.view_pose = v;
    }
    p.finish();
  }

  if (const nlohmann::json* r = top.raw_optional("render")) {
    JsonFields rf(*r, "scene.render");
    s.supersampling = rf.integer("supersampling", s.supersampling, 1, 16);
    rf.finish();
  }
  if (const nlohmann::json* c = top.raw_optional("criterion")) {
    JsonFields cf(*c, "scene.criterion");
    s.criterion.threshold = cf.number("threshold", s.criterion.threshold, 1e-3, 0.999);
    cf.finish();
  }

  parse_effects(top.raw("effects"), s);
  top.finish();

  if (s.target == TargetKind::albedo && (s.find<ContactEffect>() || s.find<ShadingEffect>()))
    throw std::invalid_argument(
        "scene: contact and shading act on a relief pressed into the gel; set target.kind to "
        "\"relief\" or remove them");
  if (s.find<ShadingEffect>() && !s.find<ContactEffect>())
    throw std::invalid_argument(
        "scene: shading needs a contact effect before it: a rigid relief step has no slope to "
        "shade, only the gel's smoothing creates one");
  return s;
}

Scene read_scene_file(const std::filesystem::path& path) {
  const nlohmann::json j = parse_json_text(read_file(path), path.string());
  try {
    return scene_from_json(j, path);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(path.string() + ": " + e.what());
  }
}

}  // namespace tactres
