// The target's ink indicator blurred by an isotropic Gaussian of sigma_mm, in
// closed form. An axis-aligned rectangle [x0, x1] x [y0, y1] blurred by G_sigma
// is separable:
//
//   C(x, y) = X(x) Y(y),  X(x) = 1/2 [erf((x1 - x) / (sqrt2 sigma)) - erf((x0 - x) / (sqrt2 sigma))]
//
// and its gradient is dC/dx = [g(x - x0) - g(x - x1)] Y(y) (likewise in y),
// with g the 1-D Gaussian density of standard deviation sigma. The shapes of a
// layout never overlap, so the pattern is the plain sum over its rectangles.
//
// Culling: a uniform grid of cells lists, per cell, the rectangles whose
// bounding box grown by cutoff = 7 sigma touches it. Beyond the cutoff a
// factor is 0 (erfc(7 / sqrt2) ~ 3e-12) and deeper than it inside, 1.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "reference_renderer.h"

namespace reference {
namespace {

// 1/2 [erf((b - t) / (sqrt2 s)) - erf((a - t) / (sqrt2 s))]: the blurred 1-D box [a, b].
double blurred_box(double a_mm, double b_mm, double sigma_mm, double t_mm) {
  const double k = 1.0 / (std::sqrt(2.0) * sigma_mm);
  return 0.5 * (std::erf((b_mm - t_mm) * k) - std::erf((a_mm - t_mm) * k));
}

double gaussian_density(double u_mm, double sigma_mm) {
  return std::exp(-0.5 * (u_mm * u_mm) / (sigma_mm * sigma_mm)) / (std::sqrt(2 * M_PI) * sigma_mm);
}

// d/dt of blurred_box: the box's two edges, each a Gaussian bump.
double blurred_box_derivative(double a_mm, double b_mm, double sigma_mm, double t_mm) {
  return gaussian_density(t_mm - a_mm, sigma_mm) - gaussian_density(t_mm - b_mm, sigma_mm);
}

// The 1-D box factor with culling: 0 far outside, 1 deep inside.
double box_factor(double a_mm, double b_mm, double sigma_mm, double cutoff_mm, double t_mm) {
  if (t_mm < a_mm - cutoff_mm || t_mm > b_mm + cutoff_mm) return 0;
  if (t_mm > a_mm + cutoff_mm && t_mm < b_mm - cutoff_mm) return 1;
  return blurred_box(a_mm, b_mm, sigma_mm, t_mm);
}

}  // namespace

double blurred_rect(const RectMm& r, double sigma_mm, double x_mm, double y_mm) {
  return blurred_box(r.x0_mm, r.x1_mm, sigma_mm, x_mm) * blurred_box(r.y0_mm, r.y1_mm, sigma_mm, y_mm);
}

Vec2 blurred_rect_gradient_per_mm(const RectMm& r, double sigma_mm, double x_mm, double y_mm) {
  const double X = blurred_box(r.x0_mm, r.x1_mm, sigma_mm, x_mm);
  const double Y = blurred_box(r.y0_mm, r.y1_mm, sigma_mm, y_mm);
  return {blurred_box_derivative(r.x0_mm, r.x1_mm, sigma_mm, x_mm) * Y,
          X * blurred_box_derivative(r.y0_mm, r.y1_mm, sigma_mm, y_mm)};
}

BlurredPattern::BlurredPattern(std::vector<RectMm> rects_mm, double sigma_mm, double cutoff_sigmas)
    : rects_mm_(std::move(rects_mm)), sigma_mm_(sigma_mm), cutoff_mm_(cutoff_sigmas * sigma_mm) {
  if (!(sigma_mm > 0)) throw std::invalid_argument("BlurredPattern: sigma_mm must be > 0");
  cell_mm_ = std::max(cutoff_mm_, 0.05);
  if (rects_mm_.empty()) return;
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (const RectMm& r : rects_mm_) {
    x0 = std::min(x0, r.x0_mm - cutoff_mm_);
    y0 = std::min(y0, r.y0_mm - cutoff_mm_);
    x1 = std::max(x1, r.x1_mm + cutoff_mm_);
    y1 = std::max(y1, r.y1_mm + cutoff_mm_);
  }
  origin_x_mm_ = x0;
  origin_y_mm_ = y0;
  cells_x_ = static_cast<int>(std::ceil((x1 - x0) / cell_mm_)) + 1;
  cells_y_ = static_cast<int>(std::ceil((y1 - y0) / cell_mm_)) + 1;
  cells_.assign(static_cast<size_t>(cells_x_) * cells_y_, {});
  for (int i = 0; i < static_cast<int>(rects_mm_.size()); ++i) {
    const RectMm& r = rects_mm_[i];
    const int cx0 = static_cast<int>((r.x0_mm - cutoff_mm_ - x0) / cell_mm_);
    const int cx1 = static_cast<int>((r.x1_mm + cutoff_mm_ - x0) / cell_mm_);
    const int cy0 = static_cast<int>((r.y0_mm - cutoff_mm_ - y0) / cell_mm_);
    const int cy1 = static_cast<int>((r.y1_mm + cutoff_mm_ - y0) / cell_mm_);
    for (int cy = cy0; cy <= cy1; ++cy)
      for (int cx = cx0; cx <= cx1; ++cx) cells_[static_cast<size_t>(cy) * cells_x_ + cx].push_back(i);
  }
}

const std::vector<int>* BlurredPattern::cell_of(double x_mm, double y_mm) const {
  const double fx = (x_mm - origin_x_mm_) / cell_mm_, fy = (y_mm - origin_y_mm_) / cell_mm_;
  if (!(fx >= 0 && fy >= 0 && fx < cells_x_ && fy < cells_y_)) return nullptr;  // also rejects NaN
  return &cells_[static_cast<size_t>(fy) * cells_x_ + static_cast<size_t>(fx)];
}

double BlurredPattern::coverage(double x_mm, double y_mm) const {
  const std::vector<int>* cell = cell_of(x_mm, y_mm);
  if (!cell) return 0;
  double sum = 0;
  for (int i : *cell) {
    const RectMm& r = rects_mm_[i];
    const double X = box_factor(r.x0_mm, r.x1_mm, sigma_mm_, cutoff_mm_, x_mm);
    if (X == 0) continue;
    sum += X * box_factor(r.y0_mm, r.y1_mm, sigma_mm_, cutoff_mm_, y_mm);
  }
  return sum;
}

Vec2 BlurredPattern::coverage_gradient_per_mm(double x_mm, double y_mm) const {
  const std::vector<int>* cell = cell_of(x_mm, y_mm);
  Vec2 g{0, 0};
  if (!cell) return g;
  for (int i : *cell) {
    const RectMm& r = rects_mm_[i];
    if (x_mm < r.x0_mm - cutoff_mm_ || x_mm > r.x1_mm + cutoff_mm_) continue;
    if (y_mm < r.y0_mm - cutoff_mm_ || y_mm > r.y1_mm + cutoff_mm_) continue;
    const Vec2 gr = blurred_rect_gradient_per_mm(r, sigma_mm_, x_mm, y_mm);
    g[0] += gr[0];
    g[1] += gr[1];
  }
  return g;
}

}  // namespace reference
