#pragma once
// Internals of the light path model shared by light_path.cpp (LEDs,
// aperture, T1) and light_path_guided.cpp (T2). Not a public header.

#include <vector>

#include "tactres/simulate/effects/light_path.h"

namespace tactres::light_path_detail {

// One quadrature node of the emitting aperture.
struct EmitterCell {
  Vec2 position_mm;            // sensor frame, on the diffuser
  double area_mm2 = 0.0;       // the node's quadrature weight (an area)
  double radiance_area = 0.0;  // exit radiance x area, W/sr
};

// The aperture's quadrature nodes (radiance not yet set).
std::vector<EmitterCell> sample_aperture(const LightPathOptions& o);
// T1's reduced distance: the air gap plus the slab's thickness over n.
double reduced_distance_mm(const LightPathOptions& o);
// The map's table step (LightPathOptions::table_step_mm, or automatic).
double table_step_mm(const LightPathOptions& o);
// Rough count of kernel evaluations the model and its map cost.
double quadrature_work(const LightPathOptions& o);
// The LEDs' irradiance on the diffuser's underside at plan point s, W/mm^2.
double led_irradiance(const LightPathOptions& o, Vec2 s);
// Fresnel transmittance from the cosines of the air-side and inside angles.
double fresnel_transmittance_cos(double cos_air, double cos_inside, double n);

// T2: the slab's rim, lit in plan view by the aperture, and the guided
// light it sends to the reflective layer.
class GuidedRim {
 public:
  GuidedRim() = default;
  GuidedRim(const LightPathOptions& o, const std::vector<EmitterCell>& cells);
  IrradianceVector at(Vec2 p) const;
  double flux_w() const { return flux_w_; }  // reaching the rim, air side

 private:
  struct Element {
    Vec2 q_mm, inward;
    double length_mm = 0.0;
    double air_radiance = 0.0;  // W/mm^2/sr
  };
  SlabOptics slab_;
  std::vector<Element> elements_;
  double flux_w_ = 0.0;
};

}  // namespace tactres::light_path_detail
