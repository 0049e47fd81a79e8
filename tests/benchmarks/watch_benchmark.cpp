// Live-mode benchmark (not a test): the figures `tactres bench` prints
// under "live (watch)" (bench/include/tactres/bench/bench_live.h), on their
// own and with knobs for a profiler.
// Run: ./build/tests/tactres_watch_benchmark [FRAMES [ONLY [PASSES]]]
//  FRAMES: frames per sequence (default 8);
//  ONLY: only the settings whose "mode setting" text contains it, e.g.
//        "layout" or "fast, tracked";
//  PASSES: how often each sequence is measured per setting (default 1).
#include <cstdio>
#include <cstdlib>

#include <glog/logging.h>
#include <opencv2/core.hpp>

#include "scene_fixtures.h"
#include "tactres/bench/bench_live.h"

int main(int argc, char** argv) {
  using namespace tactres;
  cv::setNumThreads(1);
  FLAGS_minloglevel = 3;  // Ceres' covariance warnings: tactres grades those fits itself
  google::InitGoogleLogging(argv[0]);
  const testing::TempDir dir("watch-bench");
  LiveBenchOptions o;
  o.frames = argc > 1 ? std::atoi(argv[1]) : 8;
  o.only = argc > 2 ? argv[2] : "";
  o.passes = argc > 3 ? std::atoi(argv[3]) : 1;
  o.out_dir = dir.path;
  o.validate();
  std::printf("tactres watch benchmark: %d drifting frames through focus per sequence, %d pass(es), one thread\n\n",
              o.frames, o.passes);
  std::printf("%s", live_bench_table_text(run_live_bench(o)).c_str());
  return 0;
}
