// Replays every fuzz corpus seed and every kept crash input
// (tests/fuzz/corpus/<entry>/*, tests/fuzz/regressions/<entry>/*) through
// the fuzz entry points, without libFuzzer: a fixed crash stays fixed in the
// normal suite. An input that crashes or breaks an invariant aborts this
// binary (the entry points abort on purpose), which fails the test.
#include <algorithm>
#include <filesystem>
#include <fstream>

#include <doctest/doctest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "fuzz_entry_points.h"
#include "scene_fixtures.h"
#include "tactres/measure/measurement_io.h"
#include "tactres/profiles/profile_sampler.h"
#include "tactres/camera/target_view.h"
#include "tactres/util/atomic_file.h"
#include "tactres/targets/coverage.h"
#include "tactres/targets/layout_json.h"

namespace fs = std::filesystem;

namespace {

std::string bytes_of(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

int replay(const tactres::fuzz::Entry& e, const fs::path& folder) {
  if (!fs::is_directory(folder)) return 0;
  std::vector<fs::path> files;
  for (const auto& f : fs::directory_iterator(folder))
    if (f.is_regular_file() && f.path().filename().string()[0] != '.') files.push_back(f.path());
  std::sort(files.begin(), files.end());
  for (const fs::path& p : files) {
    INFO("replaying " << p.string());
    const std::string b = bytes_of(p);
    e.fn(reinterpret_cast<const std::uint8_t*>(b.data()), b.size());
  }
  return static_cast<int>(files.size());
}

}  // namespace

TEST_CASE("fuzz: every corpus seed and kept regression input replays cleanly") {
  const fs::path root = fs::path(TACTRES_SOURCE_DIR) / "tests/fuzz";
  int total_regressions = 0;
  for (const tactres::fuzz::Entry& e : tactres::fuzz::entries()) {
    CAPTURE(std::string(e.name));
    const int seeds = replay(e, root / "corpus" / e.name);
    const int regressions = replay(e, root / "regressions" / e.name);
    total_regressions += regressions;
    CHECK(seeds >= 1);  // every entry has seeds to start from
    MESSAGE(std::string(e.name) << ": " << seeds << " seeds, " << regressions << " regression inputs replayed");
  }
  MESSAGE(total_regressions << " regression inputs in all");
}

TEST_CASE("fuzz: the entry points reject garbage quietly") {
  const std::string junk[] = {"", "{", "[]", "null", std::string("\x00\x01\x02", 3), std::string(64, '\xff'), std::string("TRAW\x02\x00\x02\x00\x00", 9) + "abcd"};
  for (const tactres::fuzz::Entry& e : tactres::fuzz::entries())
    for (const std::string& j : junk) e.fn(reinterpret_cast<const std::uint8_t*>(j.data()), j.size());
  CHECK(tactres::fuzz::find_entry("profile_fit") != nullptr);
  CHECK(tactres::fuzz::find_entry("no such entry") == nullptr);
}

// Writes the corpus seeds into $TACTRES_WRITE_FUZZ_SEEDS/<entry>/ (run by
// hand when an input format changes; the seeds are committed under
// tests/fuzz/corpus). Skipped unless the variable is set.
TEST_CASE("fuzz: write the corpus seeds" * doctest::skip(std::getenv("TACTRES_WRITE_FUZZ_SEEDS") == nullptr)) {
  using namespace tactres;
  using namespace tactres::testing;
  const fs::path out = std::getenv("TACTRES_WRITE_FUZZ_SEEDS");
  auto put = [&](const std::string& entry, const std::string& name, const std::string& bytes) {
    fs::create_directories(out / entry);
    std::ofstream(out / entry / name, std::ios::binary) << bytes;
  };
  // Layouts: the default one and a small one.
  put("layout_json", "default.json", layout_to_json(default_layout()).dump());
  LayoutOptions small;
  small.first_group = small.last_group = 2;
  small.field_width_mm = small.field_height_mm = 12;
  put("layout_json", "one_group.json", layout_to_json(make_layout(small)).dump());
  // Scenes: the examples.
  for (const auto& f : fs::directory_iterator(source_dir() / "examples/scenes"))
    if (f.path().extension() == ".json") put("scene_json", f.path().filename().string(), read_file(f.path()));
  // Camera models: the examples, and other lens models mrcal knows.
  for (const auto& f : fs::directory_iterator(source_dir() / "examples/cameras"))
    if (f.path().extension() == ".cameramodel") put("camera_model", f.path().filename().string(), read_file(f.path()));
  put("camera_model", "opencv4.cameramodel",
      "{ 'lensmodel': 'LENSMODEL_OPENCV4', 'intrinsics': [ 500, 500, 319.5, 239.5, -0.1, 0.01, 0.001, 0.0 ],"
      " 'imagersize': [ 640, 480 ], 'extrinsics': [ 0, 0, 0, 0, 0, 0 ] }\n");
  put("camera_model", "stereographic.cameramodel",
      "{ 'lensmodel': 'LENSMODEL_STEREOGRAPHIC', 'intrinsics': [ 300, 300, 319.5, 239.5 ],"
      " 'imagersize': [ 640, 480 ], 'extrinsics': [ 0, 0, 0, 0, 0, 0 ] }\n");

  // A capture of the target by a 320x180 pinhole (fiducials ~3 px in radius).
  const CameraModel cam = CameraModel::pinhole(140, 140, 159.5, 89.5, 320, 180);
  const RenderResult r = render_scene(albedo_scene({}, 0.8, 2), default_layout(), cam);
  cv::Mat u8;
  r.image.convertTo(u8, CV_8U, 255.0);
  put("measure_raw", "capture_pinhole_camera.raw", fuzz::encode_measure_raw(320, 180, 4 | 8, u8.ptr<std::uint8_t>(0)));
  put("measure_raw", "capture_no_camera.raw", fuzz::encode_measure_raw(320, 180, 0, u8.ptr<std::uint8_t>(0)));
  cv::Mat holes = u8.clone();
  for (int y = 60; y < 120; ++y) holes.at<std::uint8_t>(y, 150) = 255;
  put("measure_raw", "capture_nan_column.raw", fuzz::encode_measure_raw(320, 180, 1 | 4, holes.ptr<std::uint8_t>(0)));

  // Measurements: one usable, one unusable, as measure writes them.
  {
    LoadedImage img;
    img.luminance = cv::Mat();
    r.image.convertTo(img.luminance, CV_32F);
    img.width = 320;
    img.height = 180;
    img.channels = 1;
    img.pixel_format = "float";
    img.transfer = {TransferCurve::linear(), "test", false};
    const MeasureOptions o = MeasureOptions::for_preset(Preset::fast);
    MeasurementContext ctx;
    ctx.image = "capture.tif";
    ctx.design = "seed";
    ctx.layout = "layout.json";
    ctx.tactres_version = "0.1.0";
    ctx.loaded = &img;
    ctx.options = &o;
    const Measurement m = measure_capture(img, default_layout(), &cam, o);
    CHECK(m.usable);
    put("measurement_json", "usable.json", measurement_to_json(m, ctx).dump(1));
    img.luminance.setTo(0.5);
    const Measurement bad = measure_capture(img, default_layout(), &cam, o);
    put("measurement_json", "unusable.json", measurement_to_json(bad, ctx).dump(1));
  }
  if (fs::exists(source_dir() / "tests/data/report/T1C1.json"))
    put("measurement_json", "report_T1C1.json", read_file(source_dir() / "tests/data/report/T1C1.json"));

  // Images: small files of every kind load_image meets; 2 bytes first
  // (extension index, options) as the entry expects.
  {
    TempDir dir("seeds");
    cv::Mat small_f;
    cv::resize(r.image(cv::Rect(100, 40, 120, 100)), small_f, cv::Size(40, 32));
    cv::Mat s8, s16;
    small_f.convertTo(s8, CV_8U, 255.0);
    small_f.convertTo(s16, CV_16U, 65535.0);
    cv::Mat with_nan = small_f.clone();
    with_nan.at<float>(3, 3) = std::numeric_limits<float>::quiet_NaN();
    with_nan.at<float>(5, 7) = std::numeric_limits<float>::infinity();
    cv::Mat colour;
    cv::cvtColor(s8, colour, cv::COLOR_GRAY2BGR);
    struct Item { const char* name; std::uint8_t ext, opts; cv::Mat img; };
    const Item items[] = {{"u8.png", 0, 0, s8},          {"u16.tif", 1, 0, s16},   {"float_nan.exr", 2, 0, with_nan},
                          {"float_nan_reject.exr", 2, 16, with_nan}, {"rgb.png", 0, 1, colour}, {"u16_srgb.png", 0, 8, s16},
                          {"float.tif", 7, 0, small_f}};
    for (const Item& it : items) {
      const fs::path p = dir.path / (std::string("x") + fs::path(it.name).extension().string());
      write_image(p, it.img);
      std::string bytes;
      bytes.push_back(static_cast<char>(it.ext));
      bytes.push_back(static_cast<char>(it.opts));
      put("image", it.name, bytes + read_file(p));
    }
  }

  // Profile fits: real profiles sampled from a capture, and a synthetic one.
  {
    const RenderResult big = render_scene(albedo_scene({}, 1.2, 2), default_layout(), wide_angle_camera());
    const auto rt = albedo_scene({}, 1.2, 2).rt_camera_from_target(default_layout());
    const TargetView view(wide_angle_camera(), rt);
    const IndexedArtwork artwork(default_layout().artwork, 0.0);
    ProfileSamplingOptions so;
    int k = 0;
    for (const ElementLayout& e : default_layout().elements) {
      if (!((e.group == 0 && e.element == 1) || (e.group == 1 && e.element == 4) || (e.group == 2 && e.element == 3)))
        continue;
      const SampledProfile sp = sample_strip(big.image, view, artwork, element_strip(e, so), so, 0);
      REQUIRE(sp.in_view);
      ProfileFitOptions fo;
      fo.contrast = -0.94;
      put("profile_fit", "element_" + std::to_string(k++) + ".bin", fuzz::encode_profile_fit(sp.data, fo));
    }
    const SampledProfile patch = sample_strip(big.image, view, artwork,
                                              patch_strip(default_layout(), BarOrientation::vertical_bars), so, 0);
    ProfileFitOptions po;
    po.fit_contrast = true;
    po.fit_shape = false;
    put("profile_fit", "patch.bin", fuzz::encode_profile_fit(patch.data, po));
    po.signature = Signature::shading;
    put("profile_fit", "patch_shading.bin", fuzz::encode_profile_fit(patch.data, po));
  }
}
