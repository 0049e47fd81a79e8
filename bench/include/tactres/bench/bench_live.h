#pragma once
// The live-mode part of `tactres bench` (docs/BENCH.md, "Live mode"): what
// `tactres watch` costs per frame. A sequence of frames drifts (roll and
// offset change a little from frame to frame, as a target on an assembly
// jig does) while the defocus sweeps through focus; every frame is rendered
// and written as a 12-bit PNG, decoded once, and then measured from memory
// by a LiveMeasurer, one thread, in each setting: from scratch, tracked,
// and tracked with only the elements near the limit fitted.
//
// The times are medians over the frames after the first (the first frame is
// always measured from scratch), as thread CPU time (what the same work
// takes on an idle core) and wall clock. Issue #16's goals on one core:
// fast <= 10 ms from scratch and <= 5 ms tracked on a 1280x720 frame,
// balanced <= 12 ms from scratch, chart mode <= 15 ms tracked on 1.5 Mpx.

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace tactres {

struct LiveBenchOptions {
  int frames = 8;          // per sequence, [4, 1000]
  bool chart = true;       // also the 1.57 Mpx chart sequence (~1 s per frame from scratch)
  int passes = 1;          // how often each sequence is measured per setting, [1, 1000] (for a profiler)
  std::string only;        // only the settings whose "mode setting" text contains this; empty: all
  std::filesystem::path out_dir;  // the frames are written to out_dir / "live"
  void validate() const;   // throws std::invalid_argument
};

struct LiveBenchRow {
  std::string mode;         // "layout 1280x720" | "chart 1536x1024"
  std::string setting;      // e.g. "fast, tracked, near-limit"
  int frames = 0, measured = 0, tracked = 0;  // over every pass, the first frames included
  double cpu_ms_median = 0, wall_ms_median = 0;  // per frame after the first
  std::optional<double> goal_ms;                 // the goal for this setting, if it has one
  std::vector<std::pair<std::string, double>> stage_ms;  // median wall ms per stage, where it ran
  bool goal_met() const { return goal_ms && cpu_ms_median <= *goal_ms; }
};

// Renders the sequences and measures them. `progress` gets one line per setting.
std::vector<LiveBenchRow> run_live_bench(const LiveBenchOptions& options,
                                         const std::function<void(const std::string&)>& progress = {});

// The text table for stdout (with each row's stages), and a CSV
// (docs/BENCH.md, live.csv): one row per setting, absent values empty.
std::string live_bench_table_text(const std::vector<LiveBenchRow>& rows);
std::string live_bench_csv(const std::vector<LiveBenchRow>& rows);

}  // namespace tactres
