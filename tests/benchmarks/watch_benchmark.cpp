// Live-mode benchmark (not a test): the analysis time per frame of
// `tactres watch` (LiveMeasurer) on frames already in memory, one thread,
// from scratch and with tracking. Goals (issue #16), on one core:
//  - fast: a 1280x720 frame in <= 5 ms with tracking, <= 10 ms from scratch;
//  - balanced: <= 12 ms from scratch;
//  - chart mode with tracking: <= 15 ms on a 1.5 Mpx frame.
// The frames drift (roll and offset change a little from frame to frame),
// as a target on an assembly jig does; their defocus sweeps through focus.
// Run: ./build/tests/tactres_watch_benchmark [FRAMES [ONLY]]
// ONLY: run the modes whose "mode, setting" text contains it (for a profiler).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>

#include <glog/logging.h>
#include <map>
#include <opencv2/core.hpp>

#include "scene_fixtures.h"
#include "tactres/live/live_measure.h"
#include "tactres/targets/mil_std_chart.h"

using namespace tactres;
using namespace tactres::testing;

namespace {

double cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * ts.tv_sec + 1e-6 * ts.tv_nsec;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// Frame i of a sequence: roll and offset drift, defocus sweeps through focus.
Scene frame_scene(int i, int n, bool chart) {
  ViewPose v;
  v.roll_deg = 3 + 0.15 * i;
  v.offset_mm = {0.02 * i, -0.015 * i};
  if (chart) v.distance_mm = 30;  // 47 px/mm: the 22 x 17 mm chart fills most of the frame
  Scene s = albedo_scene(v, 1.1 + 0.3 * std::abs(i - n / 2), 2);
  SensorOptions sensor = sensor_40db(i + 1);
  sensor.bit_depth = 10;
  s.effects.emplace_back(sensor);
  return s;
}

std::vector<LoadedImage> render_sequence(int n, const TargetLayout& layout, const CameraModel& cam, bool chart,
                                         const TempDir& dir) {
  std::vector<LoadedImage> frames;
  for (int i = 0; i < n; ++i) {
    const RenderResult r = render_scene(frame_scene(i, n, chart), layout, cam);
    const auto path = dir.path / ("f" + std::to_string(i) + ".png");
    write_image(path, r.image, r.bits);
    frames.push_back(load_image(path));
  }
  return frames;
}

struct Mode {
  const char* name;
  Preset preset;
  bool tracking;
  LiveElements elements;
};

void run(const char* what, const std::vector<LoadedImage>& frames, const TargetLayout* layout,
         const CameraModel* cam, const Mode& mode, int passes) {
  LiveOptions o;
  o.measure = MeasureOptions::for_preset(mode.preset);
  o.chart = layout == nullptr;
  o.tracking = mode.tracking;
  o.elements = mode.elements;
  o.refit_every = 100000;  // the light does not change: only tracking is measured
  std::vector<double> wall, cpu;
  std::map<std::string, std::vector<double>> stages;
  int measured = 0, tracked = 0, total = 0;
  for (int pass = 0; pass < passes; ++pass) {
    LiveMeasurer live(o, layout, cam);
    for (size_t i = 0; i < frames.size(); ++i) {
      Frame f;
      f.index = long(i);
      f.image = frames[i];
      const double c0 = cpu_ms();
      const LiveFrameResult r = live.measure(f);
      const double c = cpu_ms() - c0;
      ++total;
      if (!r.measured) continue;
      ++measured;
      if (i == 0) continue;  // the first frame is always from scratch
      tracked += r.tracked;
      wall.push_back(r.analysis_ms);
      for (const auto& [stage, sec] : r.measurement.stage_seconds) stages[stage].push_back(1e3 * sec);
      cpu.push_back(c);
    }
  }
  std::printf("  %-10s %-34s %7.2f ms CPU  %7.2f ms wall  (%d/%d measured, %d tracked)\n", what, mode.name,
              median(cpu), median(wall), measured, total, tracked);
  std::printf("  %-10s %-34s", "", "stages (median wall ms):");
  for (const auto& [stage, ms] : stages) std::printf(" %s %.2f", stage.c_str(), median(ms));
  std::printf("\n");
}

}  // namespace

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::max(4, std::atoi(argv[1])) : 12;
  const std::string only = argc > 2 ? argv[2] : "";
  auto wanted = [&](const char* what, const Mode& m) {
    return only.empty() || (std::string(what) + " " + m.name).find(only) != std::string::npos;
  };
  cv::setNumThreads(1);
  FLAGS_minloglevel = 3;  // Ceres' covariance warnings: tactres grades those fits itself
  google::InitGoogleLogging(argv[0]);
  TempDir dir("watch-bench");
  std::printf("tactres watch benchmark: %d drifting frames through focus, frames in memory, one thread,\n", n);
  std::printf("median per frame after the first (thread CPU time; wall clock beside it)\n\n");

  const std::vector<LoadedImage> layout_frames =
      render_sequence(n, default_layout(), wide_angle_camera(), false, dir);
  std::printf("layout mode: default target, wide-angle camera 1280x720\n");
  const Mode modes[] = {
      {"fast, from scratch", Preset::fast, false, LiveElements::all},
      {"fast, tracking", Preset::fast, true, LiveElements::all},
      {"fast, tracking, near-limit", Preset::fast, true, LiveElements::near_limit},
      {"balanced, from scratch", Preset::balanced, false, LiveElements::all},
      {"balanced, tracking", Preset::balanced, true, LiveElements::all},
  };
  for (const Mode& m : modes)
    if (wanted("layout", m)) run("layout", layout_frames, &default_layout(), &wide_angle_camera(), m, 3);
  if (!only.empty() && only.find("chart") == std::string::npos) return 0;

  // 1536 x 1024 = 1.57 Mpx: the generated MIL-STD-150A chart, groups 0-5.
  const CameraModel cam = CameraModel::pinhole(1400, 1400, 767.5, 511.5, 1536, 1024);
  MilStdChartOptions co;
  co.first_group = 0;
  co.last_group = 5;
  const TargetLayout chart = make_mil_std_chart(co);
  const std::vector<LoadedImage> chart_frames = render_sequence(n, chart, cam, true, dir);
  std::printf("\nchart mode: generated MIL-STD-150A chart, pinhole 1536x1024 (1.57 Mpx)\n");
  const Mode chart_modes[] = {
      {"fast, from scratch", Preset::fast, false, LiveElements::all},
      {"fast, tracking", Preset::fast, true, LiveElements::all},
      {"fast, tracking, near-limit", Preset::fast, true, LiveElements::near_limit},
  };
  for (const Mode& m : chart_modes)
    if (wanted("chart", m)) run("chart", chart_frames, nullptr, nullptr, m, 1);
  return 0;
}
