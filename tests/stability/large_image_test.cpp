// Hard case: a large capture (8000 x 6000, 48 Mpx). The measurement runs in
// its own process (`tactres measure`), so its peak resident memory is the
// child's ru_maxrss from wait4, not this test binary's.
#include <chrono>

#include "stability_support.h"

using namespace tactres;
using namespace tactres::testing;
using namespace tactres::stability;
namespace fs = std::filesystem;

TEST_CASE("hard: a large image (8000x6000): measured, finite, exit 0, peak memory reported") {
  TempDir dir("large");
  const fs::path layout = dir.path / "layout.json";
  write_layout_file(layout, default_layout());
  // A 48 Mpx pinhole camera 6.25x finer than the example one: the target is
  // ~2700 px across, so every group is measurable.
  const CameraModel cam = CameraModel::pinhole(3500, 3500, 3999.5, 2999.5, 8000, 6000);
  const fs::path cam_path = dir.path / "large.cameramodel";
  cam.save(cam_path);
  ViewPose v;
  v.roll_deg = 3;
  const Scene s = albedo_scene(v, 2.0, 1);
  const auto t0 = std::chrono::steady_clock::now();
  fs::path file = dir.path / "large.png";
  {
    const RenderResult r = render_scene(s, default_layout(), cam);
    REQUIRE(r.image.cols == 8000);
    REQUIRE(r.image.rows == 6000);
    cv::Mat u16;
    r.image.convertTo(u16, CV_16U, 65535.0);
    write_image(file, u16);
  }
  const double render_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const Truth truth = compute_truth(s, default_layout(), cam);

  const auto t1 = std::chrono::steady_clock::now();
  const CliRun run = measure_cli(file, layout, dir.path, 0, {"--camera", cam_path.string()});
  const double measure_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  const double pixels_mb = 8000.0 * 6000.0 * 4 / 1048576.0;  // one float copy of the image
  MESSAGE("8000x6000 16-bit PNG: render+write " << render_s << " s; `tactres measure` " << measure_s
                                                 << " s, peak RSS " << run.max_rss_kb / 1024 << " MiB ("
                                                 << run.max_rss_kb / 1024.0 / pixels_mb << " float copies of the image)");
  CHECK(run.max_rss_kb > 0);
  const nlohmann::json j = nlohmann::json::parse(read_file(dir.path / "cli-out.json"));
  REQUIRE(j["usable"].get<bool>());
  CHECK(j["input"]["width"] == 8000);
  CHECK(j["input"]["height"] == 6000);
  // 135 px per mm: the limit falls inside group 4; the measurement finds
  // it within one element of the truth.
  for (const char* o : {"horizontal_bars", "vertical_bars"}) {
    CAPTURE(std::string(o));
    const Limit& tl = std::string(o) == "horizontal_bars" ? truth.horizontal : truth.vertical;
    const nlohmann::json& ml = j["limits"][o];
    CHECK(ml["resolved_any"].get<bool>() == tl.any_resolved);
    if (tl.any_resolved && ml["resolved_any"].get<bool>()) {
      const double f_true = tl.interpolated_lp_per_mm.value_or(tl.lp_per_mm);
      const double f_meas = ml["interpolated_lp_per_mm"].is_number() ? ml["interpolated_lp_per_mm"].get<double>()
                                                                     : ml["lp_per_mm"].get<double>();
      CHECK(std::abs(std::log2(f_meas / f_true)) <= 1.0 / 6 + 1e-9);  // within one element
    }
  }
}
