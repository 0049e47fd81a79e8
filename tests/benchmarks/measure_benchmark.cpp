// Measurement benchmark (not a test): analysis time per stage for a
// 1280x720 capture of the default target with each preset, beside the time
// OpenImageIO takes to decode the same file. Goal (issue #4): the balanced
// preset's whole analysis on one core takes no longer than the decode and
// at most 20 ms.
// Run: ./build/tests/tactres_measure_benchmark [REPS]
#include <algorithm>
#include <cstdio>
#include <map>

#include <opencv2/core.hpp>

#include "benchmark_timing.h"
#include "scene_fixtures.h"

using namespace tactres;
using namespace tactres::testing;

int main(int argc, char** argv) {
  const int reps = argc > 1 ? std::max(3, std::atoi(argv[1])) : 15;
  cv::setNumThreads(1);
  TempDir dir("measure-bench");
  ViewPose v;
  v.roll_deg = 3;
  Scene scene = albedo_scene(v, 1.1, 2);
  SensorOptions sensor = sensor_40db(1);
  sensor.bit_depth = 10;
  scene.effects.emplace_back(sensor);
  const RenderResult r = render_scene(scene, default_layout(), wide_angle_camera());
  std::vector<std::pair<std::string, std::filesystem::path>> files;
  files.push_back({"16-bit PNG", dir.path / "capture16.png"});
  write_image(files.back().second, r.image, r.bits);
  cv::Mat eight;
  r.image.convertTo(eight, CV_8U, 255.0 / 1023.0);
  files.push_back({"8-bit PNG", dir.path / "capture8.png"});
  write_image(files.back().second, eight);

  std::printf("tactres measure benchmark: default target, wide-angle 1280x720, one thread, median of %d\n\n", reps);
  for (const auto& [label, file] : files) {
    std::vector<double> decode;
    LoadedImage img;
    for (int i = 0; i < reps; ++i) {
      decode.push_back(seconds_of([&] { img = load_image(file); }));
    }
    std::printf("%s: OpenImageIO decode %.1f ms\n", label.c_str(), 1e3 * median(decode));
    for (Preset p : {Preset::fast, Preset::balanced, Preset::precise}) {
      const MeasureOptions o = MeasureOptions::for_preset(p);
      std::vector<double> total;
      std::map<std::string, std::vector<double>> stages;
      Measurement m;
      for (int i = 0; i < reps; ++i) {
        total.push_back(seconds_of([&] { m = measure_capture(img, default_layout(), &wide_angle_camera(), o); }));
        for (const auto& [stage, s] : m.stage_seconds) stages[stage].push_back(s);
      }
      if (!m.usable) {
        std::printf("  %-9s unusable: %s\n", to_string(p), m.problem.c_str());
        continue;
      }
      std::printf("  %-9s analysis %6.1f ms |", to_string(p), 1e3 * median(total));
      for (const auto& [stage, s] : m.stage_seconds) std::printf(" %s %.2f", stage.c_str(), 1e3 * median(stages[stage]));
      std::printf(" | H %.3f V %.3f lp/mm\n", m.horizontal.interpolated_lp_per_mm.value_or(0),
                  m.vertical.interpolated_lp_per_mm.value_or(0));
    }
  }
  return 0;
}
