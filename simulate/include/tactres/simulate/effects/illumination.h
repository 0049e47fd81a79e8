#pragma once
// Illumination effect of the scene simulator: the irradiance field E(x, y)
// that the sensor's diffusion-layer aperture casts on the gel / target plane.
//
// Model: the aperture is a uniform Lambertian emitter of radiance L, parallel
// to the target plane at distance d. The irradiance at a target point is
//   E = L \iint_A cos(t1) cos(t2) / r^2 dA = L \iint_A d^2 / r^4 dA = pi L F,
// F being the configuration (view) factor from a differential element of the
// target to the aperture. For the circle and the rectangle F has closed forms
// (Howell, A Catalog of Radiation Heat Transfer Configuration Factors:
// "differential planar element to parallel circular disk" and "... to
// parallel rectangle, normal through a corner", the latter combined over four
// corner rectangles; Modest, Radiative Heat Transfer, 3rd ed., appendix D).
// Closed forms are exact for every distance, where a fixed quadrature over
// the aperture loses accuracy once d is small against the aperture.
//
// Hot spots (images of the LEDs on the diffuser, the over-exposed patches the
// design study reports) are added as Gaussian bumps relative to the
// aperture's on-axis irradiance; `gain` scales everything (gain > 1 with the
// sensor effect's full well drives over-exposure).
//
// Scope: this is the direct geometry of a uniform aperture (light falls
// straight onto the reflective layer). A field computed by another model (the
// `light_path` effect: LEDs, diffuser, refraction in the elastomer, light
// guided through its edge; effects/light_path.h) comes in as the `mapped`
// kind: an IrradianceMap that this class grids and normalises like the
// closed forms, so the renderer sees one interface.

#include <algorithm>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "tactres/targets/geometry.h"

namespace tactres {

struct HotSpot {
  Vec2 center_mm;           // target coordinates
  double sigma_mm = 2.0;    // Gaussian sigma, [0.05, 1000] mm
  double peak_gain = 0.5;   // bump height relative to the on-axis irradiance, [0, 1000]
};

// An irradiance field computed elsewhere (effects/light_path.h), queried at
// an offset from IlluminationOptions::aperture_center_mm in target mm. Any
// unit; only ratios are used. Must be positive, finite and continuously
// differentiable wherever it is queried (the grid below is refined against
// it), and safe to call from many threads.
class IrradianceMap {
 public:
  virtual ~IrradianceMap() = default;
  virtual double irradiance_at(Vec2 offset_from_center_mm) const = 0;
};

// The light's direction as it varies over the target (effects/light_path.h):
// the in-plane irradiance over the normal one, (E_tx, E_ty) / E_n, in the
// target frame, queried at an offset from the target centre in target mm.
// The shading effect takes it instead of its fixed lights (scene.h). Same
// contract as IrradianceMap: finite, smooth, safe from many threads.
class InPlaneLightMap {
 public:
  virtual ~InPlaneLightMap() = default;
  virtual Vec2 in_plane_fraction_at(Vec2 offset_from_center_mm) const = 0;
};

struct IlluminationOptions {
  enum Shape {
    circle,     // disc of diameter aperture_width_mm
    square,     // side aperture_width_mm (aperture_height_mm is ignored)
    rectangle,  // aperture_width_mm along target x, aperture_height_mm along target y
    mapped,     // `map` gives the field; the aperture sizes are ignored, and
                // distance_mm is only the field's length scale (the grid's first step)
  };
  Shape shape = circle;
  std::shared_ptr<const IrradianceMap> map;  // mapped only
  double aperture_width_mm = 15.0;   // (0, 1000]
  double aperture_height_mm = 15.0;  // (0, 1000], rectangle only
  // From the emitting aperture to the target plane, [0.5, 1000] mm.
  double distance_mm = 18.0;
  // Where the aperture's centre projects on the target plane (target frame).
  Vec2 aperture_center_mm{10.0, 10.0};
  std::vector<HotSpot> hot_spots;
  double gain = 1.0;                 // overall scale, (0, 1e6]

  void validate() const;  // throws std::invalid_argument
};

const char* to_string(IlluminationOptions::Shape shape);
// "circle", "square" or "rectangle"; throws std::invalid_argument.
IlluminationOptions::Shape illumination_shape_from_string(const std::string& name);

// The configuration factor F from a target element at `target_mm` to the
// aperture (E = pi L F), in closed form; no hot spots, no gain. For a mapped
// field: map->irradiance_at(target_mm - aperture_center_mm), a quantity
// proportional to E (the ratios are what the field uses).
double aperture_view_factor(const IlluminationOptions& options, Vec2 target_mm);

// The field, normalised so that the aperture's foot point (aperture_center_mm)
// reads `gain` before hot spots:
//   relative_irradiance(p) = gain (F(p) / F(center) + sum_i peak_i exp(-|p - c_i|^2 / (2 sigma_i^2)))
// (each hot spot cut off beyond 6 sigma, where it is below 2e-8 of its peak).
// The field is precomputed on a regular grid over `domain_mm` and bilinearly
// interpolated (one lookup per call); the grid step is refined until the
// interpolation error, measured against the closed form at every cell's
// centre and edge midpoints, is below `tolerance` relative to the local value.
// Hot spots too narrow for a grid of 4 M nodes are instead added analytically
// per call (an exp each). Outside the domain the closed form is evaluated
// directly (correct, ~10x slower). Immutable after construction: safe to
// query from many threads.
class IlluminationField {
 public:
  // Throws std::invalid_argument for invalid options, an empty or non-finite
  // domain, a tolerance outside [1e-7, 0.1], or a domain so large for the
  // distance that the grid would need more than 16 million nodes.
  IlluminationField(const IlluminationOptions& options, const RectMm& domain_mm,
                    double tolerance = 1e-4);

  // Inline: the renderer calls this once per sub-pixel sample.
  double relative_irradiance(Vec2 target_mm) const {
    const double fx = (target_mm.x - domain_.x0) * inv_step_;
    const double fy = (target_mm.y - domain_.y0) * inv_step_;
    // Outside the grid (or a NaN position, which fails every comparison):
    // the closed form.
    if (!(fx >= 0.0 && fy >= 0.0 && fx <= max_fx_ && fy <= max_fy_) ||
        !(grid_has_hot_spots_ || options_.hot_spots.empty()))
      return slow_relative_irradiance(target_mm, fx, fy);
    return options_.gain * grid_base(fx, fy);
  }
  // The same value from the closed form (no grid); for tests and checks.
  double exact_relative_irradiance(Vec2 target_mm) const;

  const IlluminationOptions& options() const { return options_; }
  const RectMm& domain_mm() const { return domain_; }
  double grid_step_mm() const { return step_mm_; }
  int grid_columns() const { return nx_; }
  int grid_rows() const { return ny_; }
  // Largest relative interpolation error found at construction (cell centres
  // and edge midpoints of every cell, or of an even subsample of a big grid).
  double measured_grid_error() const { return measured_error_; }
  // Whether the hot spots are in the grid (else added analytically per call).
  bool grid_includes_hot_spots() const { return grid_has_hot_spots_; }

 private:
  double base_exact(Vec2 p) const;  // F(p) / F(center)
  double hot_spots_at(Vec2 p) const;
  // Bilinear interpolation of the grid at (fx, fy) in grid steps, inside it.
  double grid_base(double fx, double fy) const {
    const int ix = std::min(static_cast<int>(fx), nx_ - 2);
    const int iy = std::min(static_cast<int>(fy), ny_ - 2);
    const double tx = fx - ix, ty = fy - iy;
    const float* g = grid_.data() + static_cast<std::size_t>(iy) * nx_ + ix;
    const double top = g[0] + tx * (g[1] - g[0]);
    const double bottom = g[nx_] + tx * (g[nx_ + 1] - g[nx_]);
    return top + ty * (bottom - top);
  }
  double slow_relative_irradiance(Vec2 target_mm, double fx, double fy) const;
  double gridded_exact(Vec2 p) const;  // what the grid holds, from the closed form
  bool refine_grid(double tolerance, std::size_t max_nodes);
  void build_grid(double step_mm, int nx, int ny);
  double measure_grid_error() const;

  IlluminationOptions options_;
  RectMm domain_;
  double center_factor_ = 1.0;
  double step_mm_ = 0.0, inv_step_ = 0.0;
  int nx_ = 0, ny_ = 0;
  double max_fx_ = 0.0, max_fy_ = 0.0;
  std::vector<float> grid_;  // ny_ rows of nx_ values: F / F(center) (+ hot spots if gridded)
  double measured_error_ = 0.0;
  bool grid_has_hot_spots_ = false;
};

// The field over a target of width x height mm, as the renderer and the
// truth both use it: an unset aperture centre (NaN, scene.h) is the target
// centre, and the grid covers the target with half its size as margin.
IlluminationField target_illumination(IlluminationOptions options, double width_mm, double height_mm);

}  // namespace tactres
