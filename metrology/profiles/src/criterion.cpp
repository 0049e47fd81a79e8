#include "tactres/profiles/criterion.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

namespace tactres {

void Criterion::validate() const {
  if (!(threshold > 0 && threshold < 1))
    throw std::invalid_argument("--threshold must be in (0, 1), got " + std::to_string(threshold));
  if (!(significance_z >= 0 && significance_z <= 10))
    throw std::invalid_argument("significance z must be in [0, 10], got " +
                                std::to_string(significance_z));
}

bool is_resolved(const MPoint& p, const Criterion& c) {
  return p.usable && std::isfinite(p.m) && p.m >= c.threshold &&
         (p.m - c.significance_z * p.m_sigma > 0 || p.shown_by_dips);
}

namespace {

// Crossing of ln(m) = ln(t), linear in f^2 between (f0, m0) and (f1, m1).
// Returns f and df/dm0, df/dm1 for the uncertainty.
struct Crossing {
  double f, df_dm0, df_dm1;
};

std::optional<Crossing> crossing(double f0, double m0, double f1, double m1, double t) {
  const double floor_m = 1e-6;  // m1 may be ~0 or negative from a fit: clamp for the log
  m0 = std::max(m0, floor_m);
  m1 = std::max(m1, floor_m);
  const double l0 = std::log(m0), l1 = std::log(m1), lt = std::log(t);
  if (!(l0 >= lt && l1 < lt)) return std::nullopt;
  const double s0 = f0 * f0, s1 = f1 * f1;
  const double a = (l0 - lt) / (l0 - l1);  // fraction of the way in f^2
  const double s = s0 + a * (s1 - s0);
  const double f = std::sqrt(s);
  // da/dl0 = (lt - l1) / (l0 - l1)^2 ; da/dl1 = (l0 - lt) / (l0 - l1)^2
  const double d2 = (l0 - l1) * (l0 - l1);
  const double df_da = (s1 - s0) / (2 * f);
  return Crossing{f, df_da * ((lt - l1) / d2) / m0, df_da * ((l0 - lt) / d2) / m1};
}

}  // namespace

Limit find_limit(const std::vector<MPoint>& points, const Criterion& c) {
  Limit L;
  const MPoint* last = nullptr;  // the finest resolved element of the chain so far
  const MPoint* next = nullptr;  // the first measured element that is not resolved
  std::vector<Limit::Bridged> pending;  // unmeasured since `last`
  for (const MPoint& p : points) {
    if (p.unmeasured) {
      if (last) pending.push_back({p.group, p.element});
      continue;
    }
    if (!is_resolved(p, c)) {
      next = &p;
      break;
    }
    last = &p;
    L.bridged.insert(L.bridged.end(), pending.begin(), pending.end());
    pending.clear();
  }
  if (!last) return L;
  L.any_resolved = true;
  L.group = last->group;
  L.element = last->element;
  L.lp_per_mm = last->lp_per_mm;
  if (!next) {
    L.beyond_finest = true;
    return L;
  }
  // An unusable next element (aliased, below the sampling limit) gives no
  // crossing: the limit is the last resolved element, without interpolation.
  if (!next->usable || !std::isfinite(next->m)) return L;
  if (auto x = crossing(last->lp_per_mm, last->m, next->lp_per_mm, next->m, c.threshold)) {
    L.interpolated_lp_per_mm = x->f;
    L.uncertainty_lp_per_mm = std::hypot(x->df_dm0 * last->m_sigma, x->df_dm1 * next->m_sigma);
  }
  return L;
}

Limits find_limits(const std::vector<OrientedPoint>& points, const Criterion& c) {
  auto one = [&](BarOrientation o) {
    std::vector<MPoint> pts;
    for (const OrientedPoint& p : points)
      if (p.orientation == o) pts.push_back(p.point);
    std::sort(pts.begin(), pts.end(), [](const MPoint& a, const MPoint& b) { return a.lp_per_mm < b.lp_per_mm; });
    return find_limit(pts, c);
  };
  return {one(BarOrientation::horizontal_bars), one(BarOrientation::vertical_bars)};
}

nlohmann::json limit_to_json(const Limit& l) {
  nlohmann::json j;
  j["resolved_any"] = l.any_resolved;
  j["group"] = l.any_resolved ? nlohmann::json(l.group) : nlohmann::json();
  j["element"] = l.any_resolved ? nlohmann::json(l.element) : nlohmann::json();
  j["lp_per_mm"] = l.any_resolved ? nlohmann::json(l.lp_per_mm) : nlohmann::json();
  j["interpolated_lp_per_mm"] =
      l.interpolated_lp_per_mm ? nlohmann::json(*l.interpolated_lp_per_mm) : nlohmann::json();
  j["uncertainty_lp_per_mm"] =
      l.uncertainty_lp_per_mm ? nlohmann::json(*l.uncertainty_lp_per_mm) : nlohmann::json();
  j["beyond_finest"] = l.beyond_finest;
  j["bridged"] = nlohmann::json::array();
  for (const Limit::Bridged& b : l.bridged) j["bridged"].push_back({{"group", b.group}, {"element", b.element}});
  return j;
}

}  // namespace tactres
