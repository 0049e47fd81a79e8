// One light field for a relief's disc crescents (fiducial_light_field.h).

#include "fiducial_light_field.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>

#include <opencv2/core.hpp>

namespace tactres::locate_detail {

namespace {

// A field linear in its parameters p: d(q) = M(q) p, M(q) 2 x P.
//   focus:  p = (u, v, lambda),          d = (u - lambda q.x, v - lambda q.y)
//   linear: p = (u, v, bxx, bxy, byy),   d = (u, v) + B q, B symmetric
enum class FieldKind { focus, linear };

int parameter_count(FieldKind kind) { return kind == FieldKind::focus ? 3 : 5; }

// Row r (0: x, 1: y) of M(q).
cv::Mat_<double> design_row(FieldKind kind, Vec2 q, int r) {
  if (kind == FieldKind::focus) return r == 0 ? cv::Mat_<double>({1, 3}, {1, 0, -q.x}) : cv::Mat_<double>({1, 3}, {0, 1, -q.y});
  return r == 0 ? cv::Mat_<double>({1, 5}, {1, 0, q.x, q.y, 0}) : cv::Mat_<double>({1, 5}, {0, 1, 0, q.x, q.y});
}

struct Field {
  FieldKind kind;
  cv::Mat_<double> p;  // column
  Vec2 at(Vec2 q) const {
    return {cv::Mat_<double>(design_row(kind, q, 0) * p)(0), cv::Mat_<double>(design_row(kind, q, 1) * p)(0)};
  }
};

// The field whose direction best matches the unit directions e at the
// points q (all but `skip`, -1 for none): cross(e, d(q)) = 0 is linear in
// p, so the fit is the smallest eigenvector of the normal matrix. nullopt
// when the points leave it undetermined (fewer equations than the field
// has freedom, or a second eigenvalue near zero: e.g. collinear discs lit
// along their line, where any focus on that line fits).
std::optional<Field> fit_field(FieldKind kind, const std::vector<Vec2>& q, const std::vector<Vec2>& e, int skip) {
  const int n_params = parameter_count(kind);
  cv::Mat_<double> normal = cv::Mat_<double>::zeros(n_params, n_params);
  int used = 0;
  for (int j = 0; j < static_cast<int>(q.size()); ++j) {
    if (j == skip) continue;
    const cv::Mat_<double> row = e[j].x * design_row(kind, q[j], 1) - e[j].y * design_row(kind, q[j], 0);
    normal += row.t() * row;
    ++used;
  }
  if (used < n_params - 1) return std::nullopt;
  cv::Mat_<double> values, vectors;  // rows, by decreasing eigenvalue
  cv::eigen(normal, values, vectors);
  // The field is fixed up to scale only when one direction alone fits.
  constexpr double kUndetermined = 1e-6;
  if (!(values(n_params - 2) > kUndetermined * values(0))) return std::nullopt;
  Field f{kind, vectors.row(n_params - 1).t()};
  // Toward or away from the focus: the sign the points agree with.
  double agree = 0;
  for (int j = 0; j < static_cast<int>(q.size()); ++j) {
    if (j == skip) continue;
    const Vec2 d = f.at(q[j]);
    if (norm(d) > 0) agree += dot(d, e[j]) / norm(d);
  }
  if (agree < 0) f.p = -f.p;
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

// The largest leave-one-out deviation of one kind of field. Where the other
// points do not fix the field, the point is compared with the field of all
// points, and a field that all points together leave free checks nothing
// (180).
double worst_deviation_deg(FieldKind kind, const std::vector<Vec2>& q, const std::vector<Vec2>& e) {
  const int n = static_cast<int>(q.size());
  if (n <= parameter_count(kind) - 1) return 180;  // an exact fit: nothing left to check
  const std::optional<Field> all = fit_field(kind, q, e, -1);
  double worst = 0;
  for (int k = 0; k < n; ++k) {
    std::optional<Field> f = fit_field(kind, q, e, k);
    if (!f) f = all;
    if (!f) return 180;
    worst = std::max(worst, deviation_deg(*f, q, e[k], k));
  }
  return worst;
}

}  // namespace

LightFieldDeviation light_field_deviation(const std::vector<Vec2>& centres_px, const std::vector<Vec2>& dipoles_px) {
  LightFieldDeviation out;
  const int n = static_cast<int>(centres_px.size());
  if (n < 3 || static_cast<int>(dipoles_px.size()) != n) return out;
  // Centred and scaled to unit RMS radius, so that the field's constant and
  // its slopes weigh alike in the fit whatever the image size.
  Vec2 mean{};
  for (const Vec2& c : centres_px) mean = mean + c;
  mean = (1.0 / n) * mean;
  double spread_sq = 0;
  for (const Vec2& c : centres_px) spread_sq += dot(c - mean, c - mean);
  const double spread = std::sqrt(spread_sq / n);
  if (!(spread > 0)) return out;
  std::vector<Vec2> q, e;
  for (int k = 0; k < n; ++k) {
    if (!(norm(dipoles_px[k]) > 0)) return out;
    q.push_back((1 / spread) * (centres_px[k] - mean));
    e.push_back((1 / norm(dipoles_px[k])) * dipoles_px[k]);
  }
  out.focus_deg = worst_deviation_deg(FieldKind::focus, q, e);
  out.linear_deg = worst_deviation_deg(FieldKind::linear, q, e);
  return out;
}

bool follows_one_light(const LightFieldDeviation& d) {
  return d.focus_deg <= kMaxFocusDeviationDeg || d.linear_deg <= kMaxLinearDeviationDeg;
}

}  // namespace tactres::locate_detail
