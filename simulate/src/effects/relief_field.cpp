#include "tactres/simulate/effects/relief_field.h"

#include <cmath>
#include <numbers>
#include <stdexcept>

namespace tactres {
namespace {

std::vector<ArtworkShape> as_rectangles(const TargetLayout& layout) {
  std::vector<ArtworkShape> out;
  for (const ArtworkShape& s : layout.artwork) {
    if (s.kind == ArtworkShape::Kind::rect) {
      out.push_back(s);
    } else if (s.kind == ArtworkShape::Kind::disc) {
      // 64 horizontal strips; each strip's width makes its area exact, so
      // the disc's volume and centroid are preserved.
      const int n = 64;
      const double r = s.radius_mm, dy = 2 * r / n;
      auto segment = [&](double y) {  // area of the disc below height y (from the top)
        const double h = std::clamp(y, 0.0, 2 * r);
        const double a = r - h;  // signed distance from centre
        return r * r * std::acos(a / r) - a * std::sqrt(std::max(0.0, r * r - a * a));
      };
      for (int k = 0; k < n; ++k) {
        const double area = segment((k + 1) * dy) - segment(k * dy);
        const double half = 0.5 * area / dy;
        ArtworkShape strip = s;
        strip.kind = ArtworkShape::Kind::rect;
        strip.rect_mm = {s.center_mm.x - half, s.center_mm.y - r + k * dy, s.center_mm.x + half,
                         s.center_mm.y - r + (k + 1) * dy};
        out.push_back(strip);
      }
    } else {
      throw std::invalid_argument(
          "relief rendering supports rect and disc artwork; this layout has polygons");
    }
  }
  return out;
}

double Phi(double z) { return 0.5 * std::erfc(-z * std::numbers::sqrt2 / 2); }
double phi(double z) { return std::exp(-0.5 * z * z) / std::sqrt(2 * std::numbers::pi); }

}  // namespace

ReliefField::ReliefField(const TargetLayout& layout, double sigma_mm, double peak_height_mm)
    : rects_(as_rectangles(layout)),
      index_(rects_, 0.0),
      sigma_mm_(sigma_mm),
      height_mm_(peak_height_mm),
      reach_mm_(6 * sigma_mm) {
  if (!(sigma_mm > 0)) throw std::invalid_argument("contact sigma_mm must be > 0");
}

ReliefField::Sample ReliefField::at(Vec2 p) const {
  thread_local std::vector<int> hits;
  index_.query({p.x - reach_mm_, p.y - reach_mm_, p.x + reach_mm_, p.y + reach_mm_}, hits);
  Sample s;
  const double is = 1.0 / sigma_mm_;
  for (int i : hits) {
    const RectMm& r = rects_[i].rect_mm;
    const double ax0 = (r.x0 - p.x) * is, ax1 = (r.x1 - p.x) * is;
    const double ay0 = (r.y0 - p.y) * is, ay1 = (r.y1 - p.y) * is;
    if (ax0 > 6 || ax1 < -6 || ay0 > 6 || ay1 < -6) continue;
    const double X = Phi(ax1) - Phi(ax0), Y = Phi(ay1) - Phi(ay0);
    // d/dx [Phi((x1 - x)/s) - Phi((x0 - x)/s)] = (phi(ax0) - phi(ax1)) / s
    const double dX = (phi(ax0) - phi(ax1)) * is, dY = (phi(ay0) - phi(ay1)) * is;
    s.height_mm += X * Y;
    s.slope_x += dX * Y;
    s.slope_y += X * dY;
  }
  s.height_mm *= height_mm_;
  s.slope_x *= height_mm_;
  s.slope_y *= height_mm_;
  return s;
}

}  // namespace tactres
