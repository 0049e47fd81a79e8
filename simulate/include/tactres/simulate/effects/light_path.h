#pragma once
// The light path of the design study's sensors (T1/T2 x C1-C4), modelled
// radiometrically from the LEDs to the irradiance VECTOR at the gel's
// reflective layer. docs/LIGHT_PATH.md has the derivations, the values and
// where they come from, and the per-design results.
//
// Why a vector: the coating is Lambertian and, in the linearised shading the
// simulator uses, nothing shadows it, so its radiance is exactly
// albedo / pi * n . E_vec with E_vec = \int L(w) w dOmega. The normal
// component of E_vec sets the signal level; its in-plane component is what
// turns a slope of the pressed relief into a brightness change (a slope
// across the in-plane component's azimuth shades, a slope along a bar does
// not).
//
// Sensor frame: origin at the CMOS centre on the optical axis; x and y along
// the camera's image x and y (mrcal's camera frame); z along the optical axis
// toward the membrane; mm. The camera centre is taken at the CMOS plane (the
// 2-4 mm from a board lens to its sensor is neglected), so the membrane lies
// at z = the pose's distance_mm.
//
// ASSUMPTIONS (each is a parameter unless marked "fixed"):
//  1. LEDs: point sources at z = 0 facing +z, intensity
//     I(theta) = flux (m + 1) / (2 pi) cos^m(theta) (m = 1: Lambertian, the
//     120-degree viewing angle of PLCC/SMD white LEDs). The example scenes put
//     two 20 mW LEDs beside the lens, on ONE side of it (x = +9 mm,
//     y = +-3 mm): "beside", and a lens barrel of 14 mm.
//  2. Diffusion layer at height H: a thin Lambertian transmitter (fixed)
//     with diffuse transmittance tau: exit radiance L(s) = tau E_led(s) / pi,
//     E_led the LEDs' irradiance on its underside. An opaque, black mask
//     leaves only the aperture (C1-C4, centred on the optical axis; width
//     along x, height along y) emitting: the aperture IS the emitting window.
//     No light recycling between mask, diffuser and board (fixed).
//  3. Elastomer: one clear slab (gel plus support treated as one index),
//     square, side S, centred on the axis, thickness t, refractive index n,
//     attenuation length l, its top face carrying the reflective layer (the
//     membrane, at the pose distance). Planar, parallel to the CMOS (the
//     pose's tilt is ignored here). Fresnel losses at every air/slab entry
//     are computed (unpolarised).
//  4. T1: the aperture light crosses an air gap g = z_membrane - t - H, is
//     refracted into the slab's bottom face and falls straight onto the
//     reflective layer. Nothing else reaches it.
//  5. T2: the aperture light does NOT reach the slab's bottom face directly
//     (blocked: the design brief defines T2 as edge-lit). A fraction eta (the
//     edge coupling) of the aperture's flux reaches the slab's rim; each rim
//     element receives the flux the aperture emits toward it in plan view
//     (a Lambertian emitter's flux is uniform in azimuth; the housing is
//     assumed to turn it up into the rim without mixing azimuths). It enters
//     the edge face uniformly over the height t, Lambertian on the air side,
//     so inside it fills the refraction cone (half-angle asin(1/n)) with
//     uniform radiance. It reaches the reflective layer either directly or
//     after one total internal reflection at the bottom face; the first hit
//     on the coating ends the ray's guided path (the Lambertian coating
//     scatters it). Attenuation exp(-path / l).
//  6. Light scattered by the coating and trapped in the slab (about half of
//     it for n = 1.41) returns to the coating as a nearly normal, diffuse
//     component. Not included (fixed): it would raise the normal component of
//     every design by up to 1 / (1 - albedo (1 - 1/n^2)) (x1.8 for albedo
//     0.9) and lower every in-plane fraction by that factor alike.
//  7. The renderer needs a smooth field over a domain larger than the
//     membrane. T1's direct field is tabulated 10 mm past the slab (as if the
//     membrane's plane went on; nothing is measured there). T2's guided field
//     is tabulated only to 2 mm inside the rim (rim_margin_mm): the rim's
//     near field lies outside every bar, and the entry model (uniform over
//     the edge height) says nothing about it. Beyond the table the map
//     continues the field smoothly (coordinates saturate over 2 mm).

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "tactres/simulate/effects/illumination.h"
#include "tactres/targets/geometry.h"

namespace tactres {

struct LedSource {
  Vec2 position_mm;             // sensor frame, at z = 0
  double flux_w = 0.02;         // radiant flux into the forward hemisphere, (0, 10] W
};

struct LightPathOptions {
  enum class Type { T1, T2 };
  enum class Aperture { circle, square, rectangle };
  Type type = Type::T1;
  Aperture aperture = Aperture::circle;
  double aperture_width_mm = 15.0;   // along sensor x (circle: the diameter), (0, 200]
  double aperture_height_mm = 15.0;  // along sensor y (rectangle only), (0, 200]
  double diffuser_height_mm = 18.0;  // above the CMOS plane
  double diffuser_transmittance = 0.5;  // (0, 1]
  std::vector<LedSource> leds;
  double led_lambertian_order = 1.0;    // m in cos^m, [0.1, 100]
  double membrane_height_mm = 26.0;     // the pose's distance
  double elastomer_side_mm = 36.0;
  double elastomer_thickness_mm = 4.0;
  double refractive_index = 1.41;       // [1, 2.5]
  double attenuation_length_mm = 100.0; // e-folding length of the clear slab
  double edge_coupling = 0.5;           // T2: share of the aperture flux reaching the rim, (0, 1]
  // Numerics (not in scene files). The aperture is integrated by composite
  // 4-point Gauss-Legendre panels of at most aperture_panel_mm (polar for the
  // circle), shrunk to half T1's reduced distance when that is smaller (the
  // kernel's width); the rim in elements of rim_cell_mm; the map's table
  // step is table_step_mm, or automatic when 0 (T1: the reduced distance / 4,
  // within [0.25, 2] mm; T2: 1.25 mm). Checked against the exact sums in
  // light_path_test.cpp (<= 2e-3 where the bars are).
  double aperture_panel_mm = 3.5;
  double rim_cell_mm = 1.0;
  double table_step_mm = 0.0;
  double rim_margin_mm = 2.0;

  // Ranges, and the geometry: the diffuser below the slab with an air gap
  // (T1 needs it to refract), the T2 aperture inside the rim (the plan-view
  // transfer needs the rim around it). Throws std::invalid_argument.
  void validate() const;
};

const char* to_string(LightPathOptions::Type type);
const char* to_string(LightPathOptions::Aperture aperture);

// An irradiance vector on the membrane, sensor frame, W/mm^2. `normal` is
// the component toward the camera side, the side all the light comes from.
struct IrradianceVector {
  double x_w_per_mm2 = 0.0, y_w_per_mm2 = 0.0;
  double normal_w_per_mm2 = 0.0;

  double in_plane_w_per_mm2() const;
  double magnitude_w_per_mm2() const;
  double azimuth_deg() const;    // of the in-plane part, from +x toward +y
  double elevation_deg() const;  // above the membrane plane
};

// The quadrature model. Construction samples the aperture and, for T2, the
// rim (a few ms); at() is one evaluation of the integrals (~10-50 us).
class LightPathModel {
 public:
  explicit LightPathModel(const LightPathOptions& options);
  ~LightPathModel();
  LightPathModel(LightPathModel&&) noexcept;
  LightPathModel& operator=(LightPathModel&&) noexcept;

  IrradianceVector at(Vec2 sensor_mm) const;
  // The LEDs' irradiance on the diffuser's underside (W/mm^2).
  double diffuser_irradiance_w_per_mm2(Vec2 sensor_mm) const;
  double aperture_flux_w() const;  // leaving the aperture window
  double rim_flux_w() const;       // T2: reaching the rim (air side); 0 for T1
  const LightPathOptions& options() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// How target offsets (from the target centre, target mm) land in the sensor
// frame: the pose's roll and mirror (through_gel) and where the target centre
// sits (the pose's offset_mm).
struct MembraneMapping {
  Vec2 target_center_sensor_mm{0.0, 0.0};
  double roll_deg = 0.0;
  bool mirrored = false;  // through_gel: the half turn about the target's y axis

  Vec2 sensor_from_target_offset(Vec2 offset_mm) const;
  Vec2 target_from_sensor_vector(Vec2 v) const;  // rotates a vector back (M^T)
};

// The irradiance vector over the membrane on a regular sensor-frame grid,
// each component interpolated by Catmull-Rom (C1), continued smoothly
// beyond the tabulated zone (assumption 7). W/mm^2. The normal component is
// the illumination field; the in-plane one over it, rotated into the target
// frame, is the light's direction at each point (the shading's).
class LightPathMap final : public IrradianceMap, public InPlaneLightMap {
 public:
  LightPathMap(const LightPathModel& model, const MembraneMapping& mapping);
  double irradiance_at(Vec2 offset_from_center_mm) const override;
  Vec2 in_plane_fraction_at(Vec2 offset_from_center_mm) const override;
  double at_sensor(Vec2 sensor_mm) const;            // E_n
  IrradianceVector vector_at_sensor(Vec2 sensor_mm) const;  // sensor frame
  double table_half_width_mm() const { return half_width_mm_; }

 private:
  enum Component { normal, along_x, along_y };
  double table(Component c, int i, int j) const;
  double interpolate(Component c, Vec2 sensor_mm) const;
  MembraneMapping mapping_;
  double half_width_mm_ = 0.0, step_mm_ = 1.0, knee_mm_ = 0.0, soft_mm_ = 1.0;
  int n_ = 0;
  std::array<std::vector<double>, 3> values_;  // per component: n_ x n_, row j = y
};

// The light path resolved into the renderer's terms (docs/FORMATS.md, "Scene"):
//   input level = E(x, y) * (albedo * (1 - hx t_x(x, y) - hy t_y(x, y)) + ambient)
// with E(x, y) = E_normal(x, y) / unity_irradiance (a flat membrane reads
// albedo * E_normal / unity_irradiance) and t = E_in-plane / E_normal at
// each point, target frame (`map` as an InPlaneLightMap): the linearised
// Lambertian level albedo (E_n - hx E_tx - hy E_ty) / unity. The light at
// the target centre (azimuth, elevation; weight w = 1 / sin(elevation), so
// that w l_z = 1) is kept for reports.
struct LightPathResult {
  LightPathOptions options;
  double unity_irradiance_w_per_mm2 = 0.0;  // the exposure
  IrradianceVector at_target_center;        // sensor frame
  Vec2 in_plane_target_w_per_mm2;           // target frame
  double azimuth_deg = 0.0, elevation_deg = 90.0, weight = 1.0;  // target frame
  double illumination_gain = 1.0;           // E_normal(centre) / unity
  double length_scale_mm = 1.0;             // for the renderer's grid
  double aperture_flux_w = 0.0, rim_flux_w = 0.0;
  double build_seconds = 0.0;
  std::shared_ptr<const LightPathMap> map;
};

LightPathResult resolve_light_path(const LightPathOptions& options, const MembraneMapping& mapping,
                                   double unity_irradiance_w_per_mm2);

namespace light_path_detail {

// Unpolarised Fresnel transmittance from air into index n at incidence
// theta_air (rad).
double fresnel_transmittance(double theta_air_rad, double n);

struct SlabOptics {
  double thickness_mm = 4.0, refractive_index = 1.41, attenuation_length_mm = 100.0;
};
// Adds to `e` the irradiance at the slab's top face, plan point p, from one
// element of an edge face (plan point q, length length_mm, unit normal
// pointing into the slab, the face spanning the slab's height), lit from the
// air side by Lambertian radiance air_radiance (W/mm^2/sr): direct rays and
// rays after one total internal reflection at the bottom face, within the
// refraction cone, attenuated along their path.
void add_edge_element(const SlabOptics& slab, Vec2 p, Vec2 q, Vec2 inward_normal, double length_mm,
                      double air_radiance_w_per_mm2_sr, IrradianceVector& e);

}  // namespace light_path_detail

}  // namespace tactres
