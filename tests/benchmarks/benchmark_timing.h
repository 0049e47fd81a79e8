#pragma once
// What the benchmarks under tests/benchmarks share: the wall-clock seconds
// of one call (medians: tactres/util/order_stats.h).

#include "tactres/util/order_stats.h"
#include "tactres/util/stopwatch.h"

namespace tactres::testing {

template <class F>
double seconds_of(F&& f) {
  const Stopwatch t;
  f();
  return t.seconds();
}

}  // namespace tactres::testing
