#pragma once
// A scene: what a given sensor and camera would capture of the target
// (`tactres simulate`). The scene file lists the effects to simulate, in
// their physical order; an effect that is not listed runs no code.
// Format: docs/FORMATS.md, "Scene".

#include <array>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "tactres/profiles/criterion.h"
#include "tactres/simulate/effects/illumination.h"
#include "tactres/simulate/effects/light_path.h"
#include "tactres/simulate/effects/psf.h"
#include "tactres/simulate/effects/sensor_model.h"
#include "tactres/targets/layout.h"

#include <nlohmann/json_fwd.hpp>

namespace tactres {

inline constexpr const char* kSceneSchema = "tactres.scene/1";

// How the gel surface takes up a relief pressed into it: the surface height
// is depth_fraction * relief, smoothed by a Gaussian of sigma_mm. The
// Gaussian is the classic elastic half-space smoothing approximation: a
// membrane of thickness t spreads an indentation over ~t (Johnson, Contact
// Mechanics, 1985, ch. 3; GelSight's "thin elastomer" model).
struct ContactEffect {
  double sigma_mm = 0.04;       // (0, 5]
  double depth_fraction = 1.0;  // (0, 1]: share of the relief height the gel takes up
};

// Reflectance of the gel's coating under directional lights:
// R = albedo * sum_i w_i max(0, n . l_i) + ambient (Lambert), or its
// first-order expansion in the slope (lambert_linearised), which keeps the
// chain linear so the truth file can state m(f) analytically.
struct Light {
  double azimuth_deg = 0;     // from +x toward +y in the target frame
  double elevation_deg = 45;  // above the gel plane, (0, 90]
  double weight = 1;          // > 0
};
struct ShadingEffect {
  enum class Model { lambert, lambert_linearised };
  Model model = Model::lambert_linearised;
  double albedo = 0.8;   // (0, 1]
  double ambient = 0.0;  // [0, 1]
  std::vector<Light> lights{Light{}};
  // light_path: the light's direction varies over the target. Where set, each
  // point has one light of w l = (t_x, t_y, 1), t = E_in-plane / E_normal
  // there (target frame), and `lights` holds the target centre's, for reports.
  std::shared_ptr<const InPlaneLightMap> light_map;

  // The lights at `offset_mm` from the target centre: `lights`, or the map's
  // one light there.
  std::vector<Light> lights_at(Vec2 offset_from_center_mm) const;
};

struct VignettingEffect {
  double exponent = 4.0;  // cos^exponent of the chief-ray angle (cos^4 law), [0, 8]
};

using Effect =
    std::variant<ContactEffect, ShadingEffect, IlluminationOptions, PsfOptions, VignettingEffect, SensorOptions>;

const char* effect_name(const Effect& e);

// camera_from_target for a view given in words: the target centre on the
// optical axis at distance_mm; "through_gel" looks at the target from behind
// (mirrored); then roll about the optical axis and tilt about an axis in the
// target plane at tilt_axis_deg; then an offset of the target in mm.
struct ViewPose {
  std::string view = "direct";  // direct | through_gel
  double distance_mm = 26.0;
  double roll_deg = 0.0, tilt_deg = 0.0, tilt_axis_deg = 0.0;
  std::array<double, 2> offset_mm{0, 0};
};
enum class TargetKind { albedo, relief };

struct Scene {
  std::filesystem::path source;         // the scene file
  std::string design = "unnamed";       // e.g. "cmos", "T1C1"
  std::string description;
  std::optional<std::filesystem::path> layout_path;  // resolved against the scene's folder
  std::filesystem::path camera_path;
  TargetKind target = TargetKind::albedo;
  double ink_reflectance = 0.05, ground_reflectance = 0.85;  // albedo targets
  // The pose: in view terms (resolved against the layout's size) or as an
  // explicit mrcal rt camera_from_target.
  std::optional<ViewPose> view_pose;
  std::optional<std::array<double, 6>> rt_explicit;
  int supersampling = 2;                // sub-pixels per pixel side, [1, 16]
  Criterion criterion;
  std::vector<Effect> effects;          // physical order, each at most once
  // When the file lists "light_path": what it resolved into `effects` (one
  // ShadingEffect and one mapped IlluminationOptions) came from this, kept
  // for reports and checks. Nothing downstream needs it.
  std::optional<LightPathResult> light_path;

  std::array<double, 6> rt_camera_from_target(const TargetLayout& layout) const;

  template <class T>
  const T* find() const {
    for (const Effect& e : effects)
      if (auto* p = std::get_if<T>(&e)) return p;
    return nullptr;
  }
};

// Reads and validates a scene file: unknown keys and effects, missing or
// non-physical values and effects out of order are std::invalid_argument
// naming the field and listing what is valid; I/O is std::runtime_error.
Scene read_scene_file(const std::filesystem::path& path);
Scene scene_from_json(const nlohmann::json& j, const std::filesystem::path& source);

std::array<double, 6> rt_from_view(const ViewPose& v, double target_width_mm,
                                   double target_height_mm);

}  // namespace tactres
