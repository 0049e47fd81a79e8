// T2 of the light path model (effects/light_path.h, assumption 5): the
// aperture's light reaches the elastomer's rim and is guided to the
// reflective layer.
//
// Rim. A Lambertian element of the aperture sends flux M dA / (2 pi) per
// radian of azimuth, so a rim element subtending the plan angle dpsi from it
// receives eta L dA pi dpsi / (2 pi) (M = pi L). dpsi is the exact angle the
// straight element subtends, so every source's share sums to 2 pi around the
// closed rim: the rim receives eta times the aperture's flux.
//
// Edge to membrane. The flux of a rim element enters its edge face
// (length x t) uniformly, Lambertian on the air side: air radiance
// L_a = flux / (pi length t). Inside, the radiance is n^2 T L_a (radiance
// theorem, Fresnel T at the air-side angle) within the refraction cone, the
// rays making at most asin(1/n) with the inward normal. Unfold the bottom
// face's total internal reflection: the membrane point p (on the top face)
// sees the edge face at depths dz in [0, t] and its mirror image at
// dz in [t, 2 t]; the mirror path exists only where the bottom reflection is
// total (incidence >= asin(1/n), i.e. r <= n D for plan distance D). The
// coating ends every ray it meets, so no longer path reaches p. Each element
// of edge area dA at distance r, angle gamma to the inward normal, adds
//   dE_vec = n^2 T L_a cos(gamma) dA / r^2 exp(-r / l) w,
// w the unit vector from p toward it (normal part dz / r, in-plane (q - p) / r).
// The depth integral runs over the part of [0, 2 t] that the cone and the
// total reflection allow, by Gauss-Legendre on each of the two smooth pieces.

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "light_path_internal.h"

namespace tactres::light_path_detail {

namespace {

// 2-point Gauss-Legendre on [-1, 1]: each depth piece is smooth and at most
// t = a few mm long (exact for cubics). Against 3 points the example
// designs' field moves by <= 1e-3 relative; this is the costliest loop.
constexpr std::array<double, 2> kGaussX = {-0.5773502691896258, 0.5773502691896258};
constexpr std::array<double, 2> kGaussW = {1.0, 1.0};

}  // namespace

void add_edge_element(const SlabOptics& slab, Vec2 p, Vec2 q, Vec2 inward, double length_mm,
                      double air_radiance, IrradianceVector& e) {
  const Vec2 d = p - q;
  const double a = dot(d, inward);  // plan distance along the inward normal
  if (!(a > 0.0) || !(air_radiance > 0.0)) return;
  const double n = slab.refractive_index, t = slab.thickness_mm;
  const double d2 = dot(d, d);
  // The refraction cone: cos(gamma) = a / r >= cos(theta_c).
  const double cos_c = std::sqrt(std::max(0.0, 1.0 - 1.0 / (n * n)));
  const double r_cone = cos_c > 0.0 ? a / cos_c : 1e300;
  const double zc2 = r_cone * r_cone - d2;
  if (!(zc2 > 0.0)) return;
  const double z_cone = std::sqrt(zc2);
  // Total reflection at the bottom: r <= n D.
  const double z_tir = std::sqrt(d2 * std::max(0.0, n * n - 1.0));
  const double inv_len = 1.0 / slab.attenuation_length_mm;
  const double n2 = n * n;
  auto segment = [&](double z0, double z1) {
    if (!(z1 > z0)) return;
    const double half = 0.5 * (z1 - z0), mid = 0.5 * (z1 + z0);
    for (std::size_t k = 0; k < kGaussX.size(); ++k) {
      const double dz = mid + half * kGaussX[k];
      const double r2 = d2 + dz * dz;
      const double r = std::sqrt(r2);
      const double cos_in = a / r;
      // Air-side angle: sin(theta_air) = n sin(gamma).
      const double sin_air2 = n2 * (1.0 - cos_in * cos_in);
      const double cos_air = std::sqrt(std::max(0.0, 1.0 - sin_air2));
      const double radiance = n2 * fresnel_transmittance_cos(cos_air, cos_in, n) * air_radiance;
      const double w = half * kGaussW[k] * length_mm * radiance * cos_in / r2 * std::exp(-r * inv_len) / r;
      e.normal_w_per_mm2 += w * dz;
      e.x_w_per_mm2 -= w * d.x;  // toward q
      e.y_w_per_mm2 -= w * d.y;
    }
  };
  segment(0.0, std::min(t, z_cone));                          // straight from the edge
  segment(t, std::min({2.0 * t, z_cone, z_tir}));             // after one total reflection
}

GuidedRim::GuidedRim(const LightPathOptions& o, const std::vector<EmitterCell>& cells) {
  slab_ = {o.elastomer_thickness_mm, o.refractive_index, o.attenuation_length_mm};
  const double half = 0.5 * o.elastomer_side_mm;
  const int per_side = std::max(4, static_cast<int>(std::ceil(o.elastomer_side_mm / o.rim_cell_mm)));
  const double len = o.elastomer_side_mm / per_side;
  // Four sides, counter-clockwise; each element from a to b, inward normal.
  struct Side {
    Vec2 start, dir, inward;
  };
  const Side sides[4] = {{{-half, -half}, {1, 0}, {0, 1}},
                         {{half, -half}, {0, 1}, {-1, 0}},
                         {{half, half}, {-1, 0}, {0, -1}},
                         {{-half, half}, {0, -1}, {1, 0}}};
  for (const Side& s : sides)
    for (int i = 0; i < per_side; ++i) {
      const Vec2 a = s.start + (i * len) * s.dir, b = s.start + ((i + 1) * len) * s.dir;
      double flux = 0.0;
      for (const EmitterCell& c : cells) {
        const Vec2 u = a - c.position_mm, v = b - c.position_mm;
        const double dpsi = std::abs(std::atan2(cross(u, v), dot(u, v)));
        flux += 0.5 * c.radiance_area * dpsi;  // pi L A dpsi / (2 pi)
      }
      flux *= o.edge_coupling;
      flux_w_ += flux;
      const Element el{0.5 * (a + b), s.inward, len,
                       flux / (std::numbers::pi * len * o.elastomer_thickness_mm)};
      elements_.push_back(el);
    }
}

IrradianceVector GuidedRim::at(Vec2 p) const {
  IrradianceVector e;
  for (const Element& el : elements_) add_edge_element(slab_, p, el.q_mm, el.inward, el.length_mm, el.air_radiance, e);
  return e;
}

}  // namespace tactres::light_path_detail
