#pragma once
// One orientation's measured limit against the truth's, as the e2e relief
// suites check it: an orientation the truth resolves nowhere must not be
// claimed; otherwise the interpolated limit within `tolerance` (relative)
// and the discrete limit by the acceptance rule (discrete_limit_agrees).
// Returns the relative error of the interpolated limit (0 when none).
#include <cmath>

#include <doctest/doctest.h>

#include "scene_fixtures.h"

namespace tactres::testing {

inline double check_limit(const Limit& measured, const Limit& true_limit, double tolerance) {
  if (!true_limit.any_resolved) {
    CHECK_FALSE(measured.any_resolved);
    return 0.0;
  }
  REQUIRE(true_limit.interpolated_lp_per_mm);
  REQUIRE(measured.interpolated_lp_per_mm);
  const double rel = *measured.interpolated_lp_per_mm / *true_limit.interpolated_lp_per_mm - 1;
  CHECK(std::abs(rel) <= tolerance);
  CHECK(discrete_limit_agrees(measured, true_limit));
  return rel;
}

}  // namespace tactres::testing
