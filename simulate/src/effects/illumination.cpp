// Irradiance from a parallel Lambertian aperture, by configuration factors.
//
// References: J. R. Howell, A Catalog of Radiation Heat Transfer
// Configuration Factors (thermalradiation.net),
// differential planar element to a parallel disk (off-axis) and to a
// parallel rectangle (normal through a corner); M. F. Modest, Radiative Heat
// Transfer, 3rd ed., appendix D. Derivation of the forms used below:
//
// Rectangle. Integrating d^2 / (x^2 + y^2 + d^2)^2 over [0, a] x [0, b] gives
//   G(a, b) = 1/2 [ a / sqrt(a^2 + d^2) atan(b / sqrt(a^2 + d^2))
//                 + b / sqrt(b^2 + d^2) atan(a / sqrt(b^2 + d^2)) ],
// i.e. pi times the catalogue's corner factor. G is odd in a and in b, so a
// rectangle [x0, x1] x [y0, y1] (relative to the target point) has
//   F = (G(x1, y1) - G(x0, y1) - G(x1, y0) + G(x0, y0)) / pi.
//
// Disc of radius R, target point at lateral offset rho from its axis:
//   F = 1/2 (1 - a / s),  a = d^2 + rho^2 - R^2,
//   s = sqrt((d^2 + rho^2 + R^2)^2 - 4 rho^2 R^2) = sqrt((d^2 + (rho - R)^2)(d^2 + (rho + R)^2)).
// For a >= 0 (outside, or far) 1 - a/s cancels; since s^2 - a^2 = 4 R^2 d^2,
// the same value is F = 2 R^2 d^2 / (s (s + a)), which does not. On the axis
// F = R^2 / (R^2 + d^2), far away F -> R^2 d^2 / (rho^2 + d^2)^2 (small source).

#include "tactres/simulate/effects/illumination.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <fmt/format.h>
#include <opencv2/core.hpp>

namespace tactres {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kHotSpotCutoffSigmas = 6.0;  // exp(-18) = 1.5e-8 of the peak
constexpr std::size_t kMaxGridNodes = 16u << 20;
constexpr std::size_t kHotSpotGridBudget = 4u << 20;

bool finite_in(double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; }

double corner_integral(double a, double b, double d2) {
  const double ra = std::sqrt(a * a + d2), rb = std::sqrt(b * b + d2);
  return 0.5 * (a / ra * std::atan(b / ra) + b / rb * std::atan(a / rb));
}

double rectangle_factor(double x0, double y0, double x1, double y1, double d) {
  const double d2 = d * d;
  return (corner_integral(x1, y1, d2) - corner_integral(x0, y1, d2) -
          corner_integral(x1, y0, d2) + corner_integral(x0, y0, d2)) /
         kPi;
}

double disc_factor(double rho, double radius, double d) {
  const double d2 = d * d, r2 = radius * radius;
  const double a = d2 + rho * rho - r2;
  const double s = std::sqrt((d2 + (rho - radius) * (rho - radius)) * (d2 + (rho + radius) * (rho + radius)));
  return a >= 0.0 ? 2.0 * r2 * d2 / (s * (s + a)) : 0.5 * (1.0 - a / s);
}

}  // namespace

void IlluminationOptions::validate() const {
  if (shape != circle && shape != square && shape != rectangle && shape != mapped)
    throw std::invalid_argument(fmt::format(
        "illumination: aperture shape {} is unknown: use circle, square or rectangle",
        static_cast<int>(shape)));
  if (shape == mapped && !map)
    throw std::invalid_argument(
        "illumination: a mapped field needs its irradiance map (the light_path effect makes it)");
  if (!(std::isfinite(aperture_width_mm) && aperture_width_mm > 0.0 && aperture_width_mm <= 1000.0))
    throw std::invalid_argument(fmt::format(
        "illumination: aperture_width_mm must be in (0, 1000] mm (the circle's diameter, the "
        "square's side), got {}",
        aperture_width_mm));
  if (shape == rectangle && !(std::isfinite(aperture_height_mm) && aperture_height_mm > 0.0 &&
                              aperture_height_mm <= 1000.0))
    throw std::invalid_argument(fmt::format(
        "illumination: aperture_height_mm must be in (0, 1000] mm, got {}", aperture_height_mm));
  if (!finite_in(distance_mm, 0.5, 1000.0))
    throw std::invalid_argument(fmt::format(
        "illumination: distance_mm (aperture to target plane) must be in [0.5, 1000] mm, got {}",
        distance_mm));
  if (!std::isfinite(aperture_center_mm.x) || !std::isfinite(aperture_center_mm.y))
    throw std::invalid_argument("illumination: aperture_center_mm must be finite");
  if (!(std::isfinite(gain) && gain > 0.0 && gain <= 1e6))
    throw std::invalid_argument(
        fmt::format("illumination: gain must be in (0, 1e6], got {}", gain));
  for (std::size_t i = 0; i < hot_spots.size(); ++i) {
    const HotSpot& h = hot_spots[i];
    if (!std::isfinite(h.center_mm.x) || !std::isfinite(h.center_mm.y))
      throw std::invalid_argument(
          fmt::format("illumination: hot spot {}: center_mm must be finite", i));
    if (!finite_in(h.sigma_mm, 0.05, 1000.0))
      throw std::invalid_argument(fmt::format(
          "illumination: hot spot {}: sigma_mm must be in [0.05, 1000] mm, got {}", i, h.sigma_mm));
    if (!finite_in(h.peak_gain, 0.0, 1000.0))
      throw std::invalid_argument(fmt::format(
          "illumination: hot spot {}: peak_gain must be in [0, 1000] (relative to the on-axis "
          "irradiance), got {}",
          i, h.peak_gain));
  }
}

const char* to_string(IlluminationOptions::Shape shape) {
  switch (shape) {
    case IlluminationOptions::circle: return "circle";
    case IlluminationOptions::square: return "square";
    case IlluminationOptions::rectangle: return "rectangle";
    case IlluminationOptions::mapped: return "mapped";
  }
  return "unknown";
}

IlluminationOptions::Shape illumination_shape_from_string(const std::string& name) {
  for (auto s : {IlluminationOptions::circle, IlluminationOptions::square,
                 IlluminationOptions::rectangle})
    if (name == to_string(s)) return s;
  throw std::invalid_argument(fmt::format(
      "aperture shape \"{}\" is unknown: use circle, square or rectangle", name));
}

double aperture_view_factor(const IlluminationOptions& o, Vec2 p) {
  if (o.shape == IlluminationOptions::mapped)
    return o.map->irradiance_at({p.x - o.aperture_center_mm.x, p.y - o.aperture_center_mm.y});
  const double dx = o.aperture_center_mm.x - p.x, dy = o.aperture_center_mm.y - p.y;
  switch (o.shape) {
    case IlluminationOptions::circle:
      return disc_factor(std::hypot(dx, dy), 0.5 * o.aperture_width_mm, o.distance_mm);
    case IlluminationOptions::square:
    case IlluminationOptions::rectangle: {
      const double hw = 0.5 * o.aperture_width_mm;
      const double hh = 0.5 * (o.shape == IlluminationOptions::square ? o.aperture_width_mm
                                                                      : o.aperture_height_mm);
      return rectangle_factor(dx - hw, dy - hh, dx + hw, dy + hh, o.distance_mm);
    }
    case IlluminationOptions::mapped: break;  // handled above
  }
  return 0.0;
}

IlluminationField::IlluminationField(const IlluminationOptions& options, const RectMm& domain_mm,
                                     double tolerance)
    : options_(options), domain_(domain_mm) {
  options_.validate();
  if (!(std::isfinite(domain_.x0) && std::isfinite(domain_.y0) && std::isfinite(domain_.x1) &&
        std::isfinite(domain_.y1) && domain_.x1 > domain_.x0 && domain_.y1 > domain_.y0))
    throw std::invalid_argument(fmt::format(
        "illumination: the domain must be a finite, non-empty rectangle, got [{}, {}] x [{}, {}] mm",
        domain_.x0, domain_.x1, domain_.y0, domain_.y1));
  if (!finite_in(tolerance, 1e-7, 0.1))
    throw std::invalid_argument(fmt::format(
        "illumination: the grid tolerance must be in [1e-7, 0.1] (relative), got {}", tolerance));
  center_factor_ = aperture_view_factor(options_, options_.aperture_center_mm);
  if (!(std::isfinite(center_factor_) && center_factor_ > 0.0))
    throw std::invalid_argument(fmt::format(
        "illumination: the irradiance at the aperture's foot point must be positive and finite "
        "(it normalises the field), got {}",
        center_factor_));

  // Hot spots go into the grid too when their width allows a moderate one
  // (then every query is one bilinear lookup); narrow spots over a large
  // domain are evaluated analytically on top of a grid of the aperture part.
  if (!options_.hot_spots.empty()) {
    grid_has_hot_spots_ = true;
    if (refine_grid(tolerance, kHotSpotGridBudget)) return;
  }
  grid_has_hot_spots_ = false;
  if (!refine_grid(tolerance, kMaxGridNodes))
    throw std::invalid_argument(fmt::format(
        "illumination: a {:g} x {:g} mm domain at distance {:g} mm needs a grid step of about "
        "{:.3g} mm for tolerance {:g}, over the limit of 16 M nodes: use a smaller domain, a "
        "larger distance or a looser tolerance",
        domain_.width_mm(), domain_.height_mm(), options_.distance_mm, step_mm_, tolerance));
}

bool IlluminationField::refine_grid(double tolerance, std::size_t max_nodes) {
  // The aperture part varies on the scale of the distance (the kernel
  // d^2 / r^4 is d wide; curvature ~2 / d^2 per axis suggests a step ~d / 80
  // for 1e-4), a hot spot on the scale of its sigma. Start coarser and let
  // the measured error decide.
  double step = options_.distance_mm / 40.0;
  if (grid_has_hot_spots_)
    for (const HotSpot& h : options_.hot_spots) step = std::min(step, h.sigma_mm / 8.0);
  for (int attempt = 0; attempt < 10; ++attempt) {
    const double nx = std::ceil(domain_.width_mm() / step) + 1.0;
    const double ny = std::ceil(domain_.height_mm() / step) + 1.0;
    step_mm_ = step;
    if (nx * ny > static_cast<double>(max_nodes)) return false;
    build_grid(step, static_cast<int>(nx), static_cast<int>(ny));
    measured_error_ = measure_grid_error();
    if (measured_error_ <= 0.8 * tolerance) return true;
    // Bilinear error scales as step^2.
    step *= 0.9 * std::sqrt(0.8 * tolerance / measured_error_);
  }
  return false;
}

void IlluminationField::build_grid(double step_mm, int nx, int ny) {
  step_mm_ = step_mm;
  inv_step_ = 1.0 / step_mm;
  nx_ = std::max(2, nx);
  ny_ = std::max(2, ny);
  max_fx_ = nx_ - 1;
  max_fy_ = ny_ - 1;
  grid_.assign(static_cast<std::size_t>(nx_) * ny_, 0.0f);
  cv::parallel_for_(cv::Range(0, ny_), [&](const cv::Range& rows) {
    for (int j = rows.start; j < rows.end; ++j)
      for (int i = 0; i < nx_; ++i)
        grid_[static_cast<std::size_t>(j) * nx_ + i] = static_cast<float>(
            gridded_exact({domain_.x0 + i * step_mm_, domain_.y0 + j * step_mm_}));
  });
}

double IlluminationField::measure_grid_error() const {
  // Bilinear error of a smooth function peaks at a cell's centre (same-sign
  // curvatures) or at an edge midpoint (saddle): check all three per cell,
  // for every cell of a moderate grid, a regular subsample of a big one.
  const int stride = std::max(1, static_cast<int>(std::sqrt((double(nx_) * ny_) / 250000.0)));
  std::vector<double> row_worst(static_cast<std::size_t>(ny_), 0.0);
  cv::parallel_for_(cv::Range(0, ny_ - 1), [&](const cv::Range& rows) {
    for (int j = rows.start; j < rows.end; ++j) {
      if (j % stride != 0 && j != ny_ - 2) continue;
      double worst = 0.0;
      for (int i = 0; i < nx_ - 1; i += stride) {
        const double x = domain_.x0 + i * step_mm_, y = domain_.y0 + j * step_mm_;
        const double hs = 0.5 * step_mm_;
        for (const Vec2 p : {Vec2{x + hs, y + hs}, Vec2{x + hs, y}, Vec2{x, y + hs}}) {
          const double exact = gridded_exact(p);
          const double interp =
              grid_base((p.x - domain_.x0) * inv_step_, (p.y - domain_.y0) * inv_step_);
          worst = std::max(worst, std::abs(interp - exact) / std::max(exact, 1e-12));
        }
      }
      row_worst[static_cast<std::size_t>(j)] = worst;
    }
  });
  return *std::max_element(row_worst.begin(), row_worst.end());
}

double IlluminationField::base_exact(Vec2 p) const {
  return aperture_view_factor(options_, p) / center_factor_;
}

double IlluminationField::hot_spots_at(Vec2 p) const {
  double sum = 0.0;
  for (const HotSpot& h : options_.hot_spots) {
    const double dx = p.x - h.center_mm.x, dy = p.y - h.center_mm.y;
    const double r2 = dx * dx + dy * dy;
    const double s2 = h.sigma_mm * h.sigma_mm;
    if (r2 < kHotSpotCutoffSigmas * kHotSpotCutoffSigmas * s2)
      sum += h.peak_gain * std::exp(-0.5 * r2 / s2);
  }
  return sum;
}

double IlluminationField::gridded_exact(Vec2 p) const {
  return grid_has_hot_spots_ ? base_exact(p) + hot_spots_at(p) : base_exact(p);
}

double IlluminationField::slow_relative_irradiance(Vec2 p, double fx, double fy) const {
  // Inside the grid this is only reached when the grid lacks the hot spots.
  const bool inside = fx >= 0.0 && fy >= 0.0 && fx <= max_fx_ && fy <= max_fy_;
  return options_.gain * (inside ? grid_base(fx, fy) + hot_spots_at(p)
                                 : base_exact(p) + hot_spots_at(p));
}

double IlluminationField::exact_relative_irradiance(Vec2 p) const {
  return options_.gain * (base_exact(p) + hot_spots_at(p));
}

IlluminationField target_illumination(IlluminationOptions options, double width_mm, double height_mm) {
  if (std::isnan(options.aperture_center_mm.x)) options.aperture_center_mm = {0.5 * width_mm, 0.5 * height_mm};
  return IlluminationField(options, RectMm{-0.5 * width_mm, -0.5 * height_mm, 1.5 * width_mm, 1.5 * height_mm});
}

}  // namespace tactres
