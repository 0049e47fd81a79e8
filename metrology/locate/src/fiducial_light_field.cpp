// One light field for a relief's disc crescents (fiducial_light_field.h).

#include "fiducial_light_field.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>

#include <opencv2/core.hpp>

namespace tactres::locate_detail {

namespace {

// The field d(q) = (u - lambda q.x, v - lambda q.y) as (u, v, lambda).
struct Field {
  double u = 0, v = 0, lambda = 0;
  Vec2 at(Vec2 q) const { return {u - lambda * q.x, v - lambda * q.y}; }
};

// The field whose direction best matches the unit directions e at the
// points q (all but `skip`, -1 for none): cross(e, d(q)) = 0 is linear in
// (u, v, lambda), so the fit is the smallest eigenvector of the normal
// matrix. nullopt when the points leave it undetermined (a second
// eigenvalue near zero: e.g. collinear discs lit along their line, where
// any focus on that line fits), too few points, or a field that vanishes.
std::optional<Field> fit_field(const std::vector<Vec2>& q, const std::vector<Vec2>& e, int skip) {
  cv::Matx33d normal = cv::Matx33d::zeros();
  int used = 0;
  for (int j = 0; j < static_cast<int>(q.size()); ++j) {
    if (j == skip) continue;
    const cv::Vec3d row{-e[j].y, e[j].x, e[j].y * q[j].x - e[j].x * q[j].y};
    normal += row * row.t();
    ++used;
  }
  if (used < 3) return std::nullopt;
  cv::Vec3d values;
  cv::Matx33d vectors;  // rows, by decreasing eigenvalue
  cv::eigen(normal, values, vectors);
  // The field is fixed up to scale only when one direction alone fits.
  constexpr double kUndetermined = 1e-6;
  if (!(values[1] > kUndetermined * values[0])) return std::nullopt;
  Field f{vectors(2, 0), vectors(2, 1), vectors(2, 2)};
  // Toward or away from the focus: the sign the points agree with.
  double agree = 0;
  for (int j = 0; j < static_cast<int>(q.size()); ++j) {
    if (j == skip) continue;
    const Vec2 d = f.at(q[j]);
    if (norm(d) > 0) agree += dot(d, e[j]) / norm(d);
  }
  if (agree < 0) f = {-f.u, -f.v, -f.lambda};
  return f;
}

// Angle (degrees) between e and the field at q, or 180 when the field
// nearly vanishes there (below kZeroFraction of its RMS over the other
// points): a strong crescent at the field's zero is no light's.
double deviation_deg(const Field& f, const std::vector<Vec2>& q, Vec2 e, int k) {
  double sum_sq = 0;
  for (int j = 0; j < static_cast<int>(q.size()); ++j)
    if (j != k) sum_sq += dot(f.at(q[j]), f.at(q[j]));
  const double rms = std::sqrt(sum_sq / static_cast<double>(q.size() - 1));
  constexpr double kZeroFraction = 0.1;
  const Vec2 d = f.at(q[k]);
  if (!(norm(d) > kZeroFraction * rms)) return 180;
  const double c = std::clamp(dot(d, e) / norm(d), -1.0, 1.0);
  return std::acos(c) * 180 / std::numbers::pi;
}

}  // namespace

double light_field_deviation_deg(const std::vector<Vec2>& centres_px, const std::vector<Vec2>& dipoles_px) {
  const int n = static_cast<int>(centres_px.size());
  if (n < 3 || static_cast<int>(dipoles_px.size()) != n) return 180;
  // Centred and scaled to unit RMS radius, so that lambda and (u, v) weigh
  // alike in the fit whatever the image size.
  Vec2 mean{};
  for (const Vec2& c : centres_px) mean = mean + c;
  mean = (1.0 / n) * mean;
  double spread_sq = 0;
  for (const Vec2& c : centres_px) spread_sq += dot(c - mean, c - mean);
  const double spread = std::sqrt(spread_sq / n);
  if (!(spread > 0)) return 180;
  std::vector<Vec2> q, e;
  for (int k = 0; k < n; ++k) {
    if (!(norm(dipoles_px[k]) > 0)) return 180;
    q.push_back((1 / spread) * (centres_px[k] - mean));
    e.push_back((1 / norm(dipoles_px[k])) * dipoles_px[k]);
  }
  // Where the other discs do not fix the field (see fit_field; always with
  // three discs), the disc is compared with the field of all discs instead.
  const std::optional<Field> all = fit_field(q, e, -1);
  double worst = 0;
  for (int k = 0; k < n; ++k) {
    std::optional<Field> f = fit_field(q, e, k);
    if (!f) f = all;
    if (!f) return 180;
    worst = std::max(worst, deviation_deg(*f, q, e[k], k));
  }
  return worst;
}

}  // namespace tactres::locate_detail
