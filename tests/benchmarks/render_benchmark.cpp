// Render benchmark (not a test): what supersampling costs and buys for a
// 1280x720 capture, and proof that unlisted effects cost nothing.
// Run: ./build/tests/tactres_render_benchmark
#include <chrono>
#include <cstdio>

#include <opencv2/core.hpp>

#include "scene_fixtures.h"

using namespace tactres;
using namespace tactres::testing;

namespace {

double seconds(const std::function<void()>& f, int reps = 1) {
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < reps; ++i) f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / reps;
}

void print_stages(const char* label, const RenderResult& r, double total) {
  std::printf("  %-34s total %7.1f ms |", label, 1e3 * total);
  for (const auto& [stage, s] : r.stage_seconds) std::printf(" %s %.1f", stage.c_str(), 1e3 * s);
  std::printf("\n");
}

}  // namespace

int main() {
  cv::setNumThreads(1);  // one core: the figures compare like with like
  const CameraModel& cam = wide_angle_camera();
  ViewPose v;
  v.roll_deg = 3;
  std::printf("tactres render benchmark: default target, wide-angle 1280x720, one thread\n\n");

  std::printf("Supersampling (albedo target, Gaussian blur 1.1 px): time and error against 8x8\n");
  Scene ref_scene = albedo_scene(v, 1.1, 8);
  const cv::Mat reference = render_scene(ref_scene, default_layout(), cam).image;
  std::printf("  %-4s %10s %14s %14s\n", "s", "time ms", "max |err|", "RMS err");
  for (int s : {1, 2, 3, 4, 6}) {
    Scene scene = albedo_scene(v, 1.1, s);
    RenderResult r;
    const double t = seconds([&] { r = render_scene(scene, default_layout(), cam); });
    const double max_err = cv::norm(r.image, reference, cv::NORM_INF);
    const double rms = cv::norm(r.image, reference, cv::NORM_L2) / std::sqrt(double(reference.total()));
    std::printf("  %-4d %10.1f %14.2e %14.2e\n", s, 1e3 * t, max_err, rms);
  }

  std::printf("\nUnlisted effects cost nothing (stage times; supersampling 2)\n");
  Scene empty = albedo_scene(v, 0.0, 2);
  Scene blur = albedo_scene(v, 1.1, 2);
  Scene full = albedo_scene(v, 1.1, 2);
  full.effects.emplace_back(VignettingEffect{});
  full.effects.emplace_back(sensor_40db(1));
  for (const auto& [label, scene] : {std::pair("no effects", &empty), std::pair("blur only", &blur),
                                     std::pair("blur + vignetting + sensor", &full)}) {
    RenderResult r;
    const double t = seconds([&] { r = render_scene(*scene, default_layout(), cam); });
    print_stages(label, r, t);
  }
  return 0;
}
