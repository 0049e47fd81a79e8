#include "tactres/profiles/detectability.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "tactres/targets/usaf_series.h"

namespace tactres {

void DetectabilityCriterion::validate() const {
  if (!(k >= 1 && k <= 100))
    throw std::invalid_argument(fmt::format("--detectability-k must be in [1, 100], got {}", k));
  if (!(significance_z >= 0 && significance_z <= 10))
    throw std::invalid_argument(fmt::format("detectability significance z must be in [0, 10], got {}", significance_z));
}

double bar_signal_ptp(double m, double contrast, double ground_level, Signature signature, double lp_per_mm) {
  const double spatial = signature == Signature::shading ? 2 * std::numbers::pi * lp_per_mm : 1.0;
  const double s = 4 / std::numbers::pi * m * std::abs(contrast) * std::abs(ground_level) * spatial;
  return std::isfinite(s) ? s : 0.0;
}

double triplet_half_width_mm(double lp_per_mm) { return 2.5 * 0.5 / lp_per_mm; }

double rms_step_over_triplet(double contrast, double contrast_slope_per_mm, double lp_per_mm) {
  const double ramp = contrast_slope_per_mm * triplet_half_width_mm(lp_per_mm);
  return std::copysign(std::sqrt(contrast * contrast + ramp * ramp / 3), contrast);
}

double element_mean_level(double contrast, double ground_level, Signature signature) {
  return signature == Signature::albedo ? ground_level * (1 + 0.5 * contrast) : ground_level;
}

double pixels_per_bar(double px_per_bar_across, double along_over_across_scale) {
  return px_per_bar_across * px_per_bar_across * kUsafBarLengthInWidths * along_over_across_scale;
}

double rose_cnr(double signal_ptp, double pixels, double noise_sd) {
  if (!(noise_sd > 0) || !(pixels > 0)) return 0.0;
  const double c = signal_ptp * std::sqrt(pixels) / noise_sd;
  return std::isfinite(c) ? c : 0.0;
}

bool is_detectable(const CnrPoint& p, const DetectabilityCriterion& c) {
  return p.usable && std::isfinite(p.cnr) && p.cnr >= c.k &&
         (p.cnr - c.significance_z * p.cnr_sigma > 0 || p.shown_by_dips);
}

Limit find_detectability_limit(const std::vector<CnrPoint>& points, const DetectabilityCriterion& c) {
  // The same chain and crossing as the optical limit, on q = CNR / (2k)
  // against the threshold 1/2: q >= 1/2 exactly when CNR >= k, the
  // significance test is unchanged by the scale, and ln q is ln CNR shifted.
  std::vector<MPoint> q;
  q.reserve(points.size());
  for (const CnrPoint& p : points) {
    MPoint m{p.group, p.element, p.lp_per_mm, p.cnr / (2 * c.k), p.cnr_sigma / (2 * c.k), p.usable};
    m.unmeasured = p.unmeasured;
    m.shown_by_dips = p.shown_by_dips;
    q.push_back(m);
  }
  return find_limit(q, Criterion{0.5, c.significance_z});
}

double exposure_factor_for_cnr(double cnr, double shot_fraction, double k) {
  if (!(cnr > 0)) return 0.0;
  const double phi = std::clamp(shot_fraction, 0.0, 1.0), k2 = k * k;
  return (k2 * phi + std::sqrt(k2 * k2 * phi * phi + 4 * cnr * cnr * k2 * (1 - phi))) / (2 * cnr * cnr);
}

std::optional<double> light_needed_factor(const std::vector<CnrPoint>& points, const Limit& optical,
                                          const DetectabilityCriterion& c) {
  if (!optical.any_resolved) return std::nullopt;
  const CnrPoint* at = nullptr;  // the optical limit's element
  const CnrPoint* next = nullptr;  // the next measured one
  for (const CnrPoint& p : points) {
    if (at && p.usable && p.cnr > 0) {
      next = &p;
      break;
    }
    if (p.group == optical.group && p.element == optical.element) at = &p;
  }
  if (!at || !at->usable || !(at->cnr > 0)) return std::nullopt;
  double cnr = at->cnr;
  if (optical.interpolated_lp_per_mm && next) {
    const double s0 = at->lp_per_mm * at->lp_per_mm, s1 = next->lp_per_mm * next->lp_per_mm;
    const double t = (*optical.interpolated_lp_per_mm * *optical.interpolated_lp_per_mm - s0) / (s1 - s0);
    cnr = std::exp(std::log(at->cnr) + std::clamp(t, 0.0, 1.0) * (std::log(next->cnr) - std::log(at->cnr)));
  }
  return exposure_factor_for_cnr(cnr, at->shot_fraction, c.k);
}

const char* to_string(LimitingFactor f) { return f == LimitingFactor::optics ? "optics" : "light/noise"; }

namespace {
// -1 when a is coarser than b, +1 when finer, 0 when the same.
int compare_limits(const Limit& a, const Limit& b) {
  if (a.any_resolved != b.any_resolved) return a.any_resolved ? 1 : -1;
  if (!a.any_resolved) return 0;
  if (a.lp_per_mm != b.lp_per_mm) return a.lp_per_mm < b.lp_per_mm ? -1 : 1;
  if (a.beyond_finest != b.beyond_finest) return a.beyond_finest ? 1 : -1;
  if (a.interpolated_lp_per_mm && b.interpolated_lp_per_mm && *a.interpolated_lp_per_mm != *b.interpolated_lp_per_mm)
    return *a.interpolated_lp_per_mm < *b.interpolated_lp_per_mm ? -1 : 1;
  return 0;
}
}  // namespace

LimitBreakdown combine_limits(const Limit& optical, const Limit& detectability) {
  LimitBreakdown b{optical, detectability, LimitingFactor::optics, std::nullopt};
  if (compare_limits(detectability, optical) < 0) b.limited_by = LimitingFactor::light_noise;
  return b;
}

LimitBreakdown decide_breakdown(std::vector<MPoint> m, std::vector<CnrPoint> cnr, const Criterion& c,
                                const DetectabilityCriterion& d) {
  auto by_frequency = [](const auto& a, const auto& b) { return a.lp_per_mm < b.lp_per_mm; };
  std::sort(m.begin(), m.end(), by_frequency);
  std::sort(cnr.begin(), cnr.end(), by_frequency);
  const Limit optical = find_limit(m, c);
  LimitBreakdown b = combine_limits(optical, find_detectability_limit(cnr, d));
  b.light_needed = light_needed_factor(cnr, optical, d);
  return b;
}

nlohmann::json breakdown_to_json(const LimitBreakdown& b, const DetectabilityCriterion& c) {
  nlohmann::json j = limit_to_json(b.reported());
  j["limited_by"] = to_string(b.limited_by);
  j["optical"] = limit_to_json(b.optical);
  j["detectability"] = limit_to_json(b.detectability);
  j["detectability"]["k"] = c.k;
  j["light_needed_factor"] = b.light_needed ? nlohmann::json(*b.light_needed) : nlohmann::json();
  return j;
}

}  // namespace tactres
