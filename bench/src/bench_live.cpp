// The live-mode bench (bench_live.h): drifting through-focus sequences,
// measured frame by frame as `tactres watch` measures them.
#include "tactres/bench/bench_live.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

#include <fmt/format.h>

#include "tactres/bench/bench.h"
#include "tactres/camera/image_io.h"
#include "tactres/live/live_measure.h"
#include "tactres/simulate/renderer.h"
#include "tactres/targets/mil_std_chart.h"
#include "tactres/util/csv.h"
#include "bench_stats.h"

namespace tactres {
namespace {

using bench_stats::median;
using bench_stats::thread_cpu_ms;

// Frame i of n: roll and offset drift, the defocus (a Gaussian of 1.1 px at
// the best focus, the middle frame) grows by 0.3 px per frame away from it,
// at 40 dB SNR.
Scene frame_scene(int i, int n, double distance_mm) {
  Scene s;
  s.design = "bench-live";
  s.target = TargetKind::albedo;
  ViewPose v;
  v.roll_deg = 3 + 0.15 * i;
  v.offset_mm = {0.02 * i, -0.015 * i};
  v.distance_mm = distance_mm;
  s.view_pose = v;
  s.supersampling = 2;
  PsfOptions psf;
  psf.kind = PsfOptions::gaussian;
  psf.sigma_px = 1.1 + 0.3 * std::abs(i - n / 2);
  s.effects.emplace_back(psf);
  s.effects.emplace_back(bench_sensor_for_snr(40, s.ground_reflectance, 7000 + std::uint64_t(i)));
  return s;
}

std::vector<LoadedImage> render_sequence(int n, double distance_mm, const TargetLayout& layout,
                                         const CameraModel& camera, const std::filesystem::path& dir,
                                         const std::string& stem) {
  std::filesystem::create_directories(dir);
  std::vector<LoadedImage> frames;
  for (int i = 0; i < n; ++i) {
    const RenderResult r = render_scene(frame_scene(i, n, distance_mm), layout, camera);
    const auto path = dir / fmt::format("{}-{:03d}.png", stem, i);
    write_image(path, r.image, r.bits);
    frames.push_back(load_image(path));
  }
  return frames;
}

struct Setting {
  const char* name;
  Preset preset;
  bool tracking;
  LiveElements elements;
  std::optional<double> goal_ms;
};

LiveBenchRow measure_sequence(const std::string& mode, const Setting& setting, const std::vector<LoadedImage>& frames,
                              const TargetLayout* layout, const CameraModel* camera, int passes) {
  LiveOptions o;
  o.measure = MeasureOptions::for_preset(setting.preset);
  o.chart = layout == nullptr;
  o.tracking = setting.tracking;
  o.elements = setting.elements;
  o.refit_every = 100000;  // the light does not change: tracking alone is measured
  LiveBenchRow row;
  row.mode = mode;
  row.setting = setting.name;
  row.goal_ms = setting.goal_ms;
  std::vector<double> cpu, wall;
  std::map<std::string, std::vector<double>> stages;
  for (int pass = 0; pass < passes; ++pass) {
    LiveMeasurer live(o, layout, camera);
    for (size_t i = 0; i < frames.size(); ++i) {
      Frame f;
      f.index = long(i);
      f.image = frames[i];
      const double c0 = thread_cpu_ms();
      const LiveFrameResult r = live.measure(f);
      const double c = thread_cpu_ms() - c0;
      ++row.frames;
      if (!r.measured) continue;
      ++row.measured;
      row.tracked += r.tracked;
      if (i == 0) continue;  // always from scratch
      cpu.push_back(c);
      wall.push_back(r.analysis_ms);
      for (const auto& [stage, seconds] : r.measurement.stage_seconds) stages[stage].push_back(1e3 * seconds);
    }
  }
  row.cpu_ms_median = median(cpu);
  row.wall_ms_median = median(wall);
  for (const auto& [stage, ms] : stages) row.stage_ms.emplace_back(stage, median(ms));
  return row;
}

}  // namespace

void LiveBenchOptions::validate() const {
  if (frames < 4 || frames > 1000) throw std::invalid_argument("live bench: frames must be in [4, 1000]");
  if (passes < 1 || passes > 1000) throw std::invalid_argument("live bench: passes must be in [1, 1000]");
  if (out_dir.empty()) throw std::invalid_argument("live bench: say where the frames are written (out_dir)");
}

std::vector<LiveBenchRow> run_live_bench(const LiveBenchOptions& options,
                                         const std::function<void(const std::string&)>& progress) {
  options.validate();
  const auto wanted = [&](const std::string& mode, const Setting& s) {
    return options.only.empty() || (mode + " " + s.name).find(options.only) != std::string::npos;
  };
  std::vector<LiveBenchRow> rows;
  auto run = [&](const std::string& mode, const std::vector<Setting>& settings, const std::vector<LoadedImage>& frames,
                 const TargetLayout* layout, const CameraModel* camera) {
    for (const Setting& s : settings) {
      if (!wanted(mode, s)) continue;
      rows.push_back(measure_sequence(mode, s, frames, layout, camera, options.passes));
      if (progress) progress(fmt::format("live {}, {}: {:.1f} ms per frame", mode, s.name, rows.back().cpu_ms_median));
    }
  };
  const std::vector<Setting> layout_settings = {
      {"fast, from scratch", Preset::fast, false, LiveElements::all, 10.0},
      {"fast, tracked", Preset::fast, true, LiveElements::all, 5.0},
      {"fast, tracked, near-limit", Preset::fast, true, LiveElements::near_limit, 5.0},
      {"balanced, from scratch", Preset::balanced, false, LiveElements::all, 12.0},
      {"balanced, tracked", Preset::balanced, true, LiveElements::all, std::nullopt},
  };
  const std::string layout_mode = "layout 1280x720";
  if (std::any_of(layout_settings.begin(), layout_settings.end(), [&](const Setting& s) { return wanted(layout_mode, s); })) {
    const TargetLayout layout = make_layout({});
    const CameraModel camera = bench_default_camera();
    const auto frames = render_sequence(options.frames, 26, layout, camera, options.out_dir / "live", "layout");
    run(layout_mode, layout_settings, frames, &layout, &camera);
  }
  const std::vector<Setting> chart_settings = {
      {"fast, from scratch", Preset::fast, false, LiveElements::all, std::nullopt},
      {"fast, tracked", Preset::fast, true, LiveElements::all, 15.0},
      {"fast, tracked, near-limit", Preset::fast, true, LiveElements::near_limit, 15.0},
  };
  const std::string chart_mode = "chart 1536x1024";
  if (options.chart &&
      std::any_of(chart_settings.begin(), chart_settings.end(), [&](const Setting& s) { return wanted(chart_mode, s); })) {
    // The generated MIL-STD-150A chart, groups 0-5 (22 x 17 mm), filling
    // most of a 1.57 Mpx frame at 47 px/mm.
    MilStdChartOptions co;
    co.first_group = 0;
    co.last_group = 5;
    const TargetLayout chart = make_mil_std_chart(co);
    const CameraModel camera = CameraModel::pinhole(1400, 1400, 767.5, 511.5, 1536, 1024);
    const auto frames = render_sequence(options.frames, 30, chart, camera, options.out_dir / "live", "chart");
    run(chart_mode, chart_settings, frames, nullptr, nullptr);
  }
  return rows;
}

std::string live_bench_table_text(const std::vector<LiveBenchRow>& rows) {
  std::string out = fmt::format("{:<16} {:<27} {:>9} {:>8} {:>6} {:>9} {:>8}\n", "live (watch)", "setting", "ms/frame",
                                "(wall)", "goal", "measured", "tracked");
  for (const LiveBenchRow& r : rows) {
    const std::string goal = r.goal_ms ? fmt::format("{:g}{}", *r.goal_ms, r.goal_met() ? "" : "!") : "";
    out += fmt::format("{:<16} {:<27} {:>9.1f} {:>8.1f} {:>6} {:>5}/{:<3} {:>8}\n", r.mode, r.setting, r.cpu_ms_median,
                       r.wall_ms_median, goal, r.measured, r.frames, r.tracked);
    std::string stages;
    for (const auto& [stage, ms] : r.stage_ms) stages += fmt::format(" {} {:.1f}", stage, ms);
    out += fmt::format("{:<16} {:<27}{}\n", "", "  stages (ms):", stages);
  }
  out += "ms/frame: median thread CPU time per frame after the first, frames in memory; goal: issue #16's, "
         "'!' where not met\n";
  return out;
}

std::string live_bench_csv(const std::vector<LiveBenchRow>& rows) {
  std::string out = "mode,setting,frames,measured,tracked,cpu_ms_median,wall_ms_median,goal_ms,goal_met,stages\n";
  for (const LiveBenchRow& r : rows) {
    std::string stages;
    for (const auto& [stage, ms] : r.stage_ms) stages += fmt::format("{}{}={:.3f}", stages.empty() ? "" : " ", stage, ms);
    out += fmt::format("{},{},{},{},{},{},{},{},{},{}\n", csv_cell(r.mode), csv_cell(r.setting), r.frames, r.measured,
                       r.tracked, csv_number(r.cpu_ms_median, 3), csv_number(r.wall_ms_median, 3),
                       csv_number(r.goal_ms, 1), r.goal_ms ? (r.goal_met() ? "true" : "false") : "", csv_cell(stages));
  }
  return out;
}

}  // namespace tactres
