#pragma once
// The resolution criterion, shared by the truth file (simulate) and the
// measurement (measure), so that both sides define "limit" identically.
//
// An element is resolved when m(f) >= threshold and m(f) is significantly
// above zero: m - z * m_sigma > 0. (Chart mode adds that both gaps of a
// photographed triplet dip, gap_dips.h, and lets a model-free reading of
// those dips show the bars above zero where a poorly fitting model's
// widened m_sigma cannot: MPoint::shown_by_dips; it has no truth file to
// match.) The discrete limit of an orientation is the finest element such
// that it and every coarser element are resolved.
// An element that was not measured (its fit failed, it is clipped, damaged,
// or out of a chart photograph's view) says nothing either way: the chain
// skips it, and continues across it when the measured elements on both
// sides are resolved; the limit lists such bridged elements.
// The interpolated limit is where m crosses the threshold between the last
// resolved element and the next one, interpolating ln(m) linearly in f^2
// (exact for a Gaussian MTF, ln m = -2 pi^2 sigma^2 f^2).

#include <optional>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "tactres/targets/layout.h"

namespace tactres {

struct Criterion {
  double threshold = 0.10;    // m(f) at the limit, in (0, 1)
  double significance_z = 2.0;  // m must exceed z standard errors above 0

  void validate() const;  // throws std::invalid_argument
};

// One element's estimate, in ascending frequency order within an orientation.
struct MPoint {
  int group = 0;
  int element = 1;
  double lp_per_mm = 0.0;
  double m = 0.0;
  double m_sigma = 0.0;   // 0 for exact truth
  bool usable = true;     // false: graded status other than ok (never resolved)
  bool unmeasured = false;  // not measured at all: skipped by the chain (implies !usable)
  // Chart photographs only: the bars stand significantly above zero by a
  // model-free reading of the triplet's gaps (m read from them is itself
  // resolved by the criterion), whatever m_sigma says; m >= threshold is
  // still required of m. Never set for a truth file.
  bool shown_by_dips = false;
};

struct Limit {
  bool any_resolved = false;
  int group = 0, element = 0;     // discrete limit (valid if any_resolved)
  double lp_per_mm = 0.0;
  // Interpolated crossing; absent when no crossing can be bracketed (nothing
  // resolved, or everything resolved up to the finest element).
  std::optional<double> interpolated_lp_per_mm;
  std::optional<double> uncertainty_lp_per_mm;  // 1-sigma, propagated from m_sigma
  bool beyond_finest = false;  // every element resolved: the limit is above the range
  struct Bridged {
    int group = 0, element = 0;
  };
  std::vector<Bridged> bridged;  // unmeasured elements the discrete limit crossed, coarse to fine
};

bool is_resolved(const MPoint& p, const Criterion& c);

// `points` must be sorted by ascending lp_per_mm.
Limit find_limit(const std::vector<MPoint>& points, const Criterion& c);

// Both orientations' limits from one list of elements in any order.
struct OrientedPoint {
  BarOrientation orientation;
  MPoint point;
};
struct Limits {
  Limit horizontal, vertical;
};
Limits find_limits(const std::vector<OrientedPoint>& points, const Criterion& c);

// {"resolved_any", "group", "element", "lp_per_mm", "interpolated_lp_per_mm",
//  "uncertainty_lp_per_mm", "beyond_finest", "bridged": [{"group", "element"}]};
// absent values are null, never NaN.
nlohmann::json limit_to_json(const Limit& limit);

}  // namespace tactres
