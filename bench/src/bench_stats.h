#pragma once
// The bench's clocks and order statistics (util/order_stats.h), shared by
// the suite's run (bench_run.cpp) and the live figures (bench_live.cpp).
// Internal to the bench module.

#include <ctime>

#include "tactres/util/order_stats.h"

namespace tactres::bench_stats {

// CPU time of the calling thread: the work done, whatever else the machine runs.
inline double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * double(ts.tv_sec) + 1e-6 * double(ts.tv_nsec);
}

using tactres::mean;
using tactres::median;
using tactres::percentile;

}  // namespace tactres::bench_stats
