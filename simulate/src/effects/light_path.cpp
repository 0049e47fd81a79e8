// The light path model (effects/light_path.h): LEDs -> diffuser aperture ->
// (T1) refraction into the slab and straight onto the reflective layer, or
// (T2) the slab's rim and light guided inside it (light_path_guided.cpp).
//
// T1 kernel. A ray reaching the membrane point p inside the slab at angle
// theta' from the normal left the diffuser at theta in air, sin(theta) =
// n sin(theta') (Snell), and its foot on the diffuser lies
//   rho(theta') = t tan(theta') + g tan(theta)
// from p in plan (t slab thickness, g air gap). The radiance inside is
// n^2 T(theta) L (radiance theorem, Fresnel transmittance T), so a diffuser
// element dA at plan distance rho contributes
//   dE_vec = n^2 T L w' dOmega',   dOmega' / dA = sin(theta') / (rho drho/dtheta'),
//   drho/dtheta' = t / cos^2(theta') + g n cos(theta') / cos^3(theta),
// w' the unit vector toward the source. Without the slab (t -> 0) this is the
// familiar T g^2 / r^4 (normal) and T g rho / r^4 (in-plane); at rho = 0 the
// slab acts as its reduced thickness t / n. Tabulated once in rho (fine
// steps, linear interpolation), then summed over the aperture's cells.

#include "tactres/simulate/effects/light_path.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <optional>
#include <stdexcept>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "light_path_internal.h"

namespace tactres {

using namespace light_path_detail;

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;
// How far T1's table runs past the slab: the renderer's domain (twice the
// target around its centre) stays inside the table's un-bent part.
constexpr double kT1TableBeyondSlabMm = 6.0;

bool finite_in(double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; }

void require(bool ok, const std::string& message) {
  if (!ok) throw std::invalid_argument("light_path: " + message);
}

// Radial kernel of the T1 path (see the top of this file), per unit radiance
// and unit source area: the normal component, and the in-plane component
// divided by rho (so that multiplying by the plan offset gives the vector).
class DirectKernel {
 public:
  DirectKernel(double gap_mm, double thickness_mm, double n, double rho_max_mm) {
    const int count = 16384;
    step_mm_ = rho_max_mm / (count - 1);
    normal_.resize(count);
    radial_.resize(count);
    const double theta_c = n > 1.0 ? std::asin(1.0 / n) : 0.5 * kPi;
    auto geometry = [&](double tp, double& rho, double& drho, double& theta_air) {
      const double s = std::min(n * std::sin(tp), 1.0 - 1e-15);
      theta_air = std::asin(s);
      const double c = std::cos(theta_air), cp = std::cos(tp);
      rho = thickness_mm * std::tan(tp) + gap_mm * s / c;
      drho = thickness_mm / (cp * cp) + gap_mm * n * cp / (c * c * c);
    };
    const double n2 = n * n;
    {  // rho = 0: the limits sin(theta') / rho -> 1 / (t + g n)
      const double d0 = thickness_mm + gap_mm * n;
      normal_[0] = n2 * fresnel_transmittance(0.0, n) / (d0 * d0);
      radial_[0] = n2 * fresnel_transmittance(0.0, n) / (d0 * d0 * d0);
    }
    double lo = 0.0;  // the previous root: rho grows with theta'
    for (int i = 1; i < count; ++i) {
      const double target = i * step_mm_;
      double a = lo, b = theta_c * (1.0 - 1e-12), tp = lo, rho = 0, drho = 1, theta_air = 0;
      // Safeguarded Newton on rho(theta') = target within [a, b].
      for (int it = 0; it < 100; ++it) {
        geometry(tp, rho, drho, theta_air);
        const double f = rho - target;
        if (std::abs(f) < 1e-12 * (1.0 + target)) break;
        (f < 0 ? a : b) = tp;
        double next = tp - f / drho;
        if (!(next > a && next < b)) next = 0.5 * (a + b);
        if (b - a < 1e-15) break;
        tp = next;
      }
      geometry(tp, rho, drho, theta_air);
      lo = tp;
      const double common = n2 * fresnel_transmittance(theta_air, n) * std::sin(tp) / (rho * drho);
      normal_[i] = common * std::cos(tp);
      radial_[i] = common * std::sin(tp) / rho;
    }
    inv_step_ = 1.0 / step_mm_;
    max_index_ = count - 1;
  }

  void at(double rho2, double& k_normal, double& k_radial) const {
    const double f = std::sqrt(rho2) * inv_step_;
    const int i = static_cast<int>(f);
    if (i >= max_index_) {  // beyond the geometry's largest distance: not reached
      k_normal = k_radial = 0.0;
      return;
    }
    const double w = f - i;
    k_normal = normal_[i] + w * (normal_[i + 1] - normal_[i]);
    k_radial = radial_[i] + w * (radial_[i + 1] - radial_[i]);
  }

 private:
  double step_mm_ = 0.0, inv_step_ = 0.0;
  int max_index_ = 0;
  std::vector<double> normal_, radial_;
};

double aperture_half_height(const LightPathOptions& o) {
  return 0.5 * (o.aperture == LightPathOptions::Aperture::rectangle ? o.aperture_height_mm
                                                                    : o.aperture_width_mm);
}

}  // namespace

namespace light_path_detail {

double fresnel_transmittance(double theta_air_rad, double n) {
  const double si = std::sin(theta_air_rad);
  return fresnel_transmittance_cos(std::cos(theta_air_rad), std::sqrt(std::max(0.0, 1.0 - si * si / (n * n))), n);
}

double fresnel_transmittance_cos(double cos_air, double cos_inside, double n) {
  const double rs = (cos_air - n * cos_inside) / (cos_air + n * cos_inside);
  const double rp = (n * cos_air - cos_inside) / (n * cos_air + cos_inside);
  return std::clamp(1.0 - 0.5 * (rs * rs + rp * rp), 0.0, 1.0);
}

double reduced_distance_mm(const LightPathOptions& o) {
  const double gap = o.membrane_height_mm - o.elastomer_thickness_mm - o.diffuser_height_mm;
  return gap + o.elastomer_thickness_mm / o.refractive_index;
}

double table_step_mm(const LightPathOptions& o) {
  if (o.table_step_mm > 0) return o.table_step_mm;
  return o.type == LightPathOptions::Type::T1 ? std::clamp(reduced_distance_mm(o) / 4, 0.25, 2.0) : 1.25;
}

// Rough count of kernel evaluations a model and its map cost (validate()).
double quadrature_work(const LightPathOptions& o) {
  const double panel = std::min(o.aperture_panel_mm, 0.5 * reduced_distance_mm(o));
  const double hw = 0.5 * o.aperture_width_mm, hh = aperture_half_height(o);
  const double aperture_nodes =
      o.aperture == LightPathOptions::Aperture::circle
          ? 4 * std::ceil(hw / panel) * 4 * std::max(16.0, std::ceil(2 * kPi * hw / panel))
          : 16 * std::ceil(2 * hw / panel) * std::ceil(2 * hh / panel);
  const double half = o.type == LightPathOptions::Type::T1 ? 0.5 * o.elastomer_side_mm + kT1TableBeyondSlabMm
                                                           : 0.5 * o.elastomer_side_mm;
  const double table_nodes = std::pow(std::ceil(2 * half / table_step_mm(o)) + 1, 2);
  const double rim = 4 * std::ceil(o.elastomer_side_mm / o.rim_cell_mm);
  return o.type == LightPathOptions::Type::T1 ? table_nodes * aperture_nodes
                                              : table_nodes * rim * 4 + rim * aperture_nodes;
}

std::vector<EmitterCell> sample_aperture(const LightPathOptions& o) {
  // Composite 4-point Gauss-Legendre: the integrands (LED light times a
  // kernel at least the reduced distance wide) are smooth over the window,
  // whose edges are the panels' edges. A rectangle: a product rule; the
  // circle: Gauss in r (with the Jacobian r) times the trapezoid rule in
  // angle (spectrally accurate for a periodic integrand). Both rules are
  // symmetric about the axes, so a symmetric light gives a symmetric sum.
  static const double gx[4] = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563, 0.8611363115940526};
  static const double gw[4] = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461, 0.3478548451374538};
  const double panel = std::min(o.aperture_panel_mm, 0.5 * reduced_distance_mm(o));
  auto rule = [&](double lo, double hi, std::vector<double>& x, std::vector<double>& w) {
    const int panels = std::max(1, static_cast<int>(std::ceil((hi - lo) / panel)));
    const double h = (hi - lo) / panels;
    for (int p = 0; p < panels; ++p)
      for (int k = 0; k < 4; ++k) {
        x.push_back(lo + (p + 0.5 + 0.5 * gx[k]) * h);
        w.push_back(0.5 * h * gw[k]);
      }
  };
  std::vector<EmitterCell> cells;
  const double hw = 0.5 * o.aperture_width_mm, hh = aperture_half_height(o);
  if (o.aperture == LightPathOptions::Aperture::circle) {
    std::vector<double> r, wr;
    rule(0.0, hw, r, wr);
    // Angular nodes: about a quarter panel apart on the rim, a multiple of 4.
    const int na = 4 * std::max(16, static_cast<int>(std::ceil(2 * kPi * hw / panel)));
    for (std::size_t i = 0; i < r.size(); ++i)
      for (int k = 0; k < na; ++k) {
        const double phi = 2 * kPi * k / na;
        cells.push_back({{r[i] * std::cos(phi), r[i] * std::sin(phi)}, wr[i] * r[i] * 2 * kPi / na, 0.0});
      }
  } else {
    std::vector<double> x, wx, y, wy;
    rule(-hw, hw, x, wx);
    rule(-hh, hh, y, wy);
    for (std::size_t j = 0; j < y.size(); ++j)
      for (std::size_t i = 0; i < x.size(); ++i) cells.push_back({{x[i], y[j]}, wx[i] * wy[j], 0.0});
  }
  return cells;
}

double led_irradiance(const LightPathOptions& o, Vec2 s) {
  // I(theta) = flux (m + 1) / (2 pi) cos^m, on a plane at H: E = I cos / r^2
  // = flux (m + 1) / (2 pi) H^(m + 1) / r^(m + 3).
  const double m = o.led_lambertian_order, h = o.diffuser_height_mm;
  double e = 0.0;
  for (const LedSource& led : o.leds) {
    const double dx = s.x - led.position_mm.x, dy = s.y - led.position_mm.y;
    const double r2 = dx * dx + dy * dy + h * h;
    e += led.flux_w * (m + 1) / (2 * kPi) * std::pow(h * h / r2, 0.5 * (m + 1)) / r2;
  }
  return e;
}

}  // namespace light_path_detail

void LightPathOptions::validate() const {
  const std::string ap = to_string(aperture);
  require(finite_in(aperture_width_mm, 0.01, 200),
          fmt::format("aperture_mm[0] (width along the sensor's x) must be in (0, 200] mm, got {}",
                      aperture_width_mm));
  require(aperture != Aperture::rectangle || finite_in(aperture_height_mm, 0.01, 200),
          fmt::format("aperture_mm[1] (height along the sensor's y) must be in (0, 200] mm, got {}",
                      aperture_height_mm));
  require(finite_in(diffuser_height_mm, 0.5, 500),
          fmt::format("diffuser_height_mm must be in [0.5, 500] mm, got {}", diffuser_height_mm));
  require(finite_in(diffuser_transmittance, 1e-3, 1),
          fmt::format("diffuser_transmittance must be in (0, 1], got {}", diffuser_transmittance));
  require(!leds.empty() && leds.size() <= 64, "needs 1 to 64 LEDs");
  for (std::size_t i = 0; i < leds.size(); ++i) {
    require(finite_in(leds[i].flux_w, 1e-9, 10),
            fmt::format("LED {}: flux must be in (0, 10000] mW, got {} mW", i, 1e3 * leds[i].flux_w));
    require(finite_in(leds[i].position_mm.x, -500, 500) && finite_in(leds[i].position_mm.y, -500, 500),
            fmt::format("LED {}: position_mm must be finite, within 500 mm of the axis", i));
  }
  require(finite_in(led_lambertian_order, 0.1, 100),
          fmt::format("led_lambertian_order must be in [0.1, 100], got {}", led_lambertian_order));
  require(finite_in(membrane_height_mm, 1, 1000),
          fmt::format("the membrane height (the pose's distance_mm) must be in [1, 1000] mm, got {}",
                      membrane_height_mm));
  require(finite_in(elastomer_side_mm, 2, 500),
          fmt::format("elastomer side_mm must be in [2, 500] mm, got {}", elastomer_side_mm));
  require(finite_in(elastomer_thickness_mm, 0.1, 50),
          fmt::format("elastomer thickness_mm must be in [0.1, 50] mm, got {}", elastomer_thickness_mm));
  require(finite_in(refractive_index, 1.0, 2.5),
          fmt::format("elastomer refractive_index must be in [1, 2.5], got {}", refractive_index));
  require(finite_in(attenuation_length_mm, 1, 1e7),
          fmt::format("elastomer attenuation_length_mm must be in [1, 1e7] mm, got {}",
                      attenuation_length_mm));
  require(finite_in(edge_coupling, 1e-6, 1),
          fmt::format("edge_coupling must be in (0, 1], got {}", edge_coupling));
  require(finite_in(aperture_panel_mm, 0.01, 10) && finite_in(rim_cell_mm, 0.01, 5) &&
              (table_step_mm == 0.0 || finite_in(table_step_mm, 0.05, 10)) && finite_in(rim_margin_mm, 0.1, 50),
          "numerical steps out of range");
  const double gap = membrane_height_mm - elastomer_thickness_mm - diffuser_height_mm;
  require(gap >= 0.05,
          fmt::format("the diffusion layer (diffuser_height_mm {} mm) must lie below the elastomer's bottom "
                      "face (membrane {} mm - thickness {} mm = {} mm), with an air gap",
                      diffuser_height_mm, membrane_height_mm, elastomer_thickness_mm,
                      membrane_height_mm - elastomer_thickness_mm));
  require(rim_margin_mm + 2 * tactres::light_path_detail::table_step_mm(*this) < 0.5 * elastomer_side_mm,
          fmt::format("elastomer side_mm {} mm leaves no membrane inside the {} mm rim margin",
                      elastomer_side_mm, rim_margin_mm));
  // Bound the work (a scene file must not ask for hours): the map's table
  // times the aperture's quadrature nodes (T1) or the rim's (T2).
  const double work = quadrature_work(*this);
  require(work <= 3e8,
          fmt::format("this geometry needs ~{:.2g} kernel evaluations (the limit is 3e8): the diffuser is too close "
                      "to the membrane for the aperture's and the elastomer's size; use a larger gap, a smaller "
                      "aperture or a smaller elastomer",
                      work));
  if (type == Type::T2)
    require(0.5 * aperture_width_mm < 0.5 * elastomer_side_mm &&
                aperture_half_height(*this) < 0.5 * elastomer_side_mm,
            fmt::format("T2: the {} aperture ({} mm) must lie inside the elastomer's rim (side {} mm): "
                        "its light is carried outward to the rim",
                        ap, aperture_width_mm, elastomer_side_mm));
}

const char* to_string(LightPathOptions::Type type) { return type == LightPathOptions::Type::T1 ? "T1" : "T2"; }

const char* to_string(LightPathOptions::Aperture a) {
  switch (a) {
    case LightPathOptions::Aperture::circle: return "circle";
    case LightPathOptions::Aperture::square: return "square";
    case LightPathOptions::Aperture::rectangle: return "rectangle";
  }
  return "unknown";
}

double IrradianceVector::in_plane_w_per_mm2() const { return std::hypot(x_w_per_mm2, y_w_per_mm2); }
double IrradianceVector::magnitude_w_per_mm2() const {
  return std::hypot(in_plane_w_per_mm2(), normal_w_per_mm2);
}
double IrradianceVector::azimuth_deg() const { return std::atan2(y_w_per_mm2, x_w_per_mm2) / kDeg; }
double IrradianceVector::elevation_deg() const {
  return std::atan2(normal_w_per_mm2, in_plane_w_per_mm2()) / kDeg;
}

struct LightPathModel::Impl {
  LightPathOptions o;
  std::vector<EmitterCell> cells;  // the aperture, radiance x area
  std::optional<DirectKernel> direct;
  GuidedRim rim;
  double aperture_flux_w = 0.0;

  explicit Impl(const LightPathOptions& options) : o(options) {
    o.validate();
    cells = sample_aperture(o);
    for (EmitterCell& c : cells) {
      // Lambertian exit: L = tau E / pi; the cell emits pi L A.
      c.radiance_area = o.diffuser_transmittance * led_irradiance(o, c.position_mm) / kPi * c.area_mm2;
      aperture_flux_w += kPi * c.radiance_area;
    }
    if (o.type == LightPathOptions::Type::T1) {
      const double half = 0.5 * o.elastomer_side_mm + kT1TableBeyondSlabMm;  // the map's table reaches this far
      const double rho_max = 1.02 * std::hypot(half + 0.5 * o.aperture_width_mm, half + aperture_half_height(o)) + 1.0;
      direct.emplace(o.membrane_height_mm - o.elastomer_thickness_mm - o.diffuser_height_mm,
                     o.elastomer_thickness_mm, o.refractive_index, rho_max);
    } else {
      rim = GuidedRim(o, cells);
    }
  }

  IrradianceVector direct_at(Vec2 p) const {
    double n = 0, x = 0, y = 0;
    for (const EmitterCell& c : cells) {
      const double dx = c.position_mm.x - p.x, dy = c.position_mm.y - p.y;
      double kn, kr;
      direct->at(dx * dx + dy * dy, kn, kr);
      n += c.radiance_area * kn;
      x += c.radiance_area * kr * dx;
      y += c.radiance_area * kr * dy;
    }
    return {x, y, n};
  }
};

LightPathModel::LightPathModel(const LightPathOptions& options) : impl_(std::make_unique<Impl>(options)) {}
LightPathModel::~LightPathModel() = default;
LightPathModel::LightPathModel(LightPathModel&&) noexcept = default;
LightPathModel& LightPathModel::operator=(LightPathModel&&) noexcept = default;

IrradianceVector LightPathModel::at(Vec2 p) const {
  return impl_->direct ? impl_->direct_at(p) : impl_->rim.at(p);
}
double LightPathModel::diffuser_irradiance_w_per_mm2(Vec2 s) const { return led_irradiance(impl_->o, s); }
double LightPathModel::aperture_flux_w() const { return impl_->aperture_flux_w; }
double LightPathModel::rim_flux_w() const { return impl_->rim.flux_w(); }
const LightPathOptions& LightPathModel::options() const { return impl_->o; }

Vec2 MembraneMapping::sensor_from_target_offset(Vec2 o) const {
  // rt_from_view: R = roll * view, view = a half turn about y when mirrored;
  // its in-plane block is Rz(roll) diag(mirrored ? -1 : 1, 1).
  const double c = std::cos(roll_deg * kDeg), s = std::sin(roll_deg * kDeg);
  const double x = mirrored ? -o.x : o.x;
  return {target_center_sensor_mm.x + c * x - s * o.y, target_center_sensor_mm.y + s * x + c * o.y};
}

Vec2 MembraneMapping::target_from_sensor_vector(Vec2 v) const {
  const double c = std::cos(roll_deg * kDeg), s = std::sin(roll_deg * kDeg);
  const double x = c * v.x + s * v.y, y = -s * v.x + c * v.y;  // Rz(-roll)
  return {mirrored ? -x : x, y};
}

LightPathMap::LightPathMap(const LightPathModel& model, const MembraneMapping& mapping) : mapping_(mapping) {
  const LightPathOptions& o = model.options();
  // T1's direct light is smooth everywhere on the membrane's plane, so the
  // table runs 6 mm past the slab (no membrane there: the continuation only
  // keeps the renderer's grid smooth over its whole domain). T2's guided
  // light is singular at the rim: the table stops rim_margin_mm inside it.
  const double half = o.type == LightPathOptions::Type::T1 ? 0.5 * o.elastomer_side_mm + kT1TableBeyondSlabMm
                                                           : 0.5 * o.elastomer_side_mm - o.rim_margin_mm;
  n_ = static_cast<int>(std::ceil(2 * half / table_step_mm(o))) + 1;
  step_mm_ = 2 * half / (n_ - 1);
  half_width_mm_ = half;
  // Beyond the knee, coordinates saturate smoothly toward the table's edge
  // (x -> knee + soft (1 - exp(-(x - knee) / soft))): C1, so the renderer's
  // bilinear grid converges (a hard clamp would leave a kink). The bend adds
  // a curvature ~ (dE/dx) / soft: 2 mm keeps it moderate.
  soft_mm_ = std::min(2.0, 0.25 * half);
  knee_mm_ = half - soft_mm_;
  for (auto& v : values_) v.assign(static_cast<std::size_t>(n_) * n_, 0.0);
  cv::parallel_for_(cv::Range(0, n_), [&](const cv::Range& rows) {
    for (int j = rows.start; j < rows.end; ++j)
      for (int i = 0; i < n_; ++i) {
        const IrradianceVector e = model.at({-half + i * step_mm_, -half + j * step_mm_});
        const std::size_t k = static_cast<std::size_t>(j) * n_ + i;
        values_[normal][k] = e.normal_w_per_mm2;
        values_[along_x][k] = e.x_w_per_mm2;
        values_[along_y][k] = e.y_w_per_mm2;
      }
  });
}

double LightPathMap::table(Component c, int i, int j) const {
  i = std::clamp(i, 0, n_ - 1);
  j = std::clamp(j, 0, n_ - 1);
  return values_[c][static_cast<std::size_t>(j) * n_ + i];
}

double LightPathMap::at_sensor(Vec2 s) const { return interpolate(normal, s); }

IrradianceVector LightPathMap::vector_at_sensor(Vec2 s) const {
  return {interpolate(along_x, s), interpolate(along_y, s), interpolate(normal, s)};
}

// Each component is interpolated on its own and the ratio taken after: the
// in-plane part changes sign across T1's spot, where a tabulated ratio
// would be as smooth but the components are what the model computes.
Vec2 LightPathMap::in_plane_fraction_at(Vec2 offset_mm) const {
  const IrradianceVector e = vector_at_sensor(mapping_.sensor_from_target_offset(offset_mm));
  const Vec2 t = mapping_.target_from_sensor_vector({e.x_w_per_mm2, e.y_w_per_mm2});
  return {t.x / e.normal_w_per_mm2, t.y / e.normal_w_per_mm2};
}

double LightPathMap::interpolate(Component c, Vec2 s) const {
  auto soften = [&](double v) {
    const double a = std::abs(v);
    if (!(a > knee_mm_)) return v;
    return std::copysign(knee_mm_ + soft_mm_ * (1.0 - std::exp(-(a - knee_mm_) / soft_mm_)), v);
  };
  const double fx = (soften(s.x) + half_width_mm_) / step_mm_;
  const double fy = (soften(s.y) + half_width_mm_) / step_mm_;
  if (!(std::isfinite(fx) && std::isfinite(fy))) return table(c, n_ / 2, n_ / 2);
  const int i = std::clamp(static_cast<int>(std::floor(fx)), 0, n_ - 2);
  const int j = std::clamp(static_cast<int>(std::floor(fy)), 0, n_ - 2);
  auto weights = [](double t, double w[4]) {  // Catmull-Rom
    const double t2 = t * t, t3 = t2 * t;
    w[0] = 0.5 * (-t3 + 2 * t2 - t);
    w[1] = 0.5 * (3 * t3 - 5 * t2 + 2);
    w[2] = 0.5 * (-3 * t3 + 4 * t2 + t);
    w[3] = 0.5 * (t3 - t2);
  };
  double wx[4], wy[4];
  weights(fx - i, wx);
  weights(fy - j, wy);
  double sum = 0.0;
  for (int b = 0; b < 4; ++b) {
    double row = 0.0;
    for (int a = 0; a < 4; ++a) row += wx[a] * table(c, i - 1 + a, j - 1 + b);
    sum += wy[b] * row;
  }
  return sum;
}

double LightPathMap::irradiance_at(Vec2 offset_mm) const {
  return at_sensor(mapping_.sensor_from_target_offset(offset_mm));
}

LightPathResult resolve_light_path(const LightPathOptions& options, const MembraneMapping& mapping,
                                   double unity_irradiance_w_per_mm2) {
  const auto t0 = std::chrono::steady_clock::now();
  require(finite_in(unity_irradiance_w_per_mm2, 1e-15, 1e3), "the exposure (unity irradiance) must be positive");
  LightPathResult r;
  const LightPathModel model(options);
  r.options = model.options();
  r.unity_irradiance_w_per_mm2 = unity_irradiance_w_per_mm2;
  const LightPathOptions& o = r.options;
  const Vec2 c = mapping.target_center_sensor_mm;
  const double zone = 0.5 * o.elastomer_side_mm - o.rim_margin_mm;
  require(std::abs(c.x) <= zone && std::abs(c.y) <= zone,
          fmt::format("the target centre (the pose's offset_mm [{}, {}]) must lie on the membrane, within "
                      "{} mm of the axis (elastomer side {} mm less the {} mm rim margin)",
                      c.x, c.y, zone, o.elastomer_side_mm, o.rim_margin_mm));
  r.map = std::make_shared<LightPathMap>(model, mapping);
  r.at_target_center = model.at(c);
  const IrradianceVector& e = r.at_target_center;
  require(std::isfinite(e.normal_w_per_mm2) && e.normal_w_per_mm2 > 0,
          "no light reaches the target centre: check the LEDs, the aperture and the elastomer");
  r.in_plane_target_w_per_mm2 = mapping.target_from_sensor_vector({e.x_w_per_mm2, e.y_w_per_mm2});
  r.azimuth_deg = std::atan2(r.in_plane_target_w_per_mm2.y, r.in_plane_target_w_per_mm2.x) / kDeg;
  r.elevation_deg = e.elevation_deg();
  r.weight = e.magnitude_w_per_mm2() / e.normal_w_per_mm2;
  r.illumination_gain = e.normal_w_per_mm2 / unity_irradiance_w_per_mm2;
  r.length_scale_mm =
      o.type == LightPathOptions::Type::T1 ? reduced_distance_mm(o) : 2 * o.elastomer_thickness_mm;
  r.aperture_flux_w = model.aperture_flux_w();
  r.rim_flux_w = model.rim_flux_w();
  r.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace tactres
