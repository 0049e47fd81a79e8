// The forward model against independent references: the generator's own
// raster, mrcal's projection, a mirror, an analytic blur, and byte-exact
// repeatability.
#include <sys/wait.h>

#include <cmath>
#include <complex>
#include <fstream>
#include <numbers>

#include <doctest/doctest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "scene_fixtures.h"
#include "tactres/locate/pose.h"
#include "tactres/simulate/effects/psf.h"
#include "tactres/util/atomic_file.h"
#include "tactres/targets/coverage.h"
#include "tactres/targets/layout_json.h"
#include "tactres/targets/raster.h"

using namespace tactres;
using namespace tactres::testing;
namespace fs = std::filesystem;

namespace {

constexpr double kPxPerMm = 24.0;
constexpr double kDistanceMm = 30.0;

// A pinhole whose pixel grid coincides with the generator's raster: target
// (0, 0) at the corner of pixel (0, 0), kPxPerMm pixels per mm.
CameraModel raster_aligned_pinhole(const TargetLayout& layout) {
  const int w = static_cast<int>(std::ceil(layout.width_mm * kPxPerMm));
  const int h = static_cast<int>(std::ceil(layout.height_mm * kPxPerMm));
  return CameraModel::pinhole(kPxPerMm * kDistanceMm, kPxPerMm * kDistanceMm, -0.5, -0.5, w, h);
}

Scene fronto_albedo() {
  Scene s;
  s.target = TargetKind::albedo;
  s.ink_reflectance = 0.0;
  s.ground_reflectance = 1.0;
  s.rt_explicit = std::array<double, 6>{0, 0, 0, 0, 0, kDistanceMm};
  s.supersampling = 1;
  return s;
}

}  // namespace

TEST_CASE("empty effect list, pinhole, fronto-parallel: the generator's raster to 1e-3") {
  const TargetLayout& layout = default_layout();
  const CameraModel cam = raster_aligned_pinhole(layout);
  const RenderResult r = render_scene(fronto_albedo(), layout, cam);
  const ImageF raster = coverage_raster(layout, kPxPerMm);
  REQUIRE(r.image.type() == CV_32F);
  REQUIRE(r.image.cols == raster.width);
  REQUIRE(r.image.rows == raster.height);
  double worst = 0;
  for (int y = 0; y < raster.height; ++y)
    for (int x = 0; x < raster.width; ++x)
      worst = std::max(worst, std::abs(double(r.image.at<float>(y, x)) - (1.0 - raster.pixels[size_t(y) * raster.width + x])));
  MESSAGE("worst pixel difference to the generator's raster: " << worst);
  CHECK(worst <= 1e-3);
}

TEST_CASE("fiducial centres land where mrcal projects them, within 0.05 px") {
  ViewPose v;
  v.roll_deg = 23;
  v.tilt_deg = 20;
  v.tilt_axis_deg = 60;
  Scene s = albedo_scene(v, 0.0, 2);
  s.ink_reflectance = 0.0;
  s.ground_reflectance = 1.0;
  const CameraModel& cam = wide_angle_camera();
  const TargetLayout& layout = default_layout();
  const RenderResult r = render_scene(s, layout, cam);
  const auto rt = s.rt_camera_from_target(layout);
  for (const Fiducial& f : layout.fiducials) {
    const auto expected = project_disc_centroid(cam, rt, f.center_mm, f.radius_mm, 720);
    REQUIRE(expected);
    // Coverage-weighted centroid of the disc's image: ink = 1 - value.
    const int r_px = 30;
    double sw = 0, sx = 0, sy = 0;
    for (int y = int(expected->y) - r_px; y <= int(expected->y) + r_px; ++y)
      for (int x = int(expected->x) - r_px; x <= int(expected->x) + r_px; ++x) {
        const double w = 1.0 - r.image.at<float>(y, x);
        sw += w;
        sx += w * x;
        sy += w * y;
      }
    const double err = std::hypot(sx / sw - expected->x, sy / sw - expected->y);
    CAPTURE(f.id);
    CHECK(err <= 0.05);
  }
}

TEST_CASE("a through-gel view is the mirror image of the direct view") {
  const CameraModel cam = CameraModel::pinhole(560, 560, 639.5, 359.5, 1280, 720);
  ViewPose direct;
  ViewPose gel;
  gel.view = "through_gel";
  const RenderResult a = render_scene(albedo_scene(direct, 1.0, 2), default_layout(), cam);
  const RenderResult b = render_scene(albedo_scene(gel, 1.0, 2), default_layout(), cam);
  cv::Mat flipped;
  cv::flip(a.image, flipped, 1);
  const double diff = cv::norm(flipped, b.image, cv::NORM_INF);
  MESSAGE("max |mirror(direct) - through_gel| = " << diff);
  CHECK(diff <= 1e-4);
  CHECK(cv::norm(a.image, b.image, cv::NORM_INF) > 0.1);  // and it is not the same image
}

TEST_CASE("blur-only renders carry the analytic m(f) of their PSF (within 0.01)") {
  const TargetLayout& layout = default_layout();
  const CameraModel cam = raster_aligned_pinhole(layout);
  const ArtworkIndex index(layout.artwork, 0.0);
  PsfOptions gaussian;
  gaussian.kind = PsfOptions::gaussian;
  gaussian.sigma_px = 1.2;
  PsfOptions disc;
  disc.kind = PsfOptions::defocus_disc;
  disc.radius_px = 2.0;
  PsfOptions airy;
  airy.kind = PsfOptions::diffraction;
  airy.f_number = 8;
  airy.wavelength_um = 0.55;
  airy.pixel_pitch_um = 1.4;
  for (const PsfOptions& psf : {gaussian, disc, airy}) {
    Scene s = fronto_albedo();
    s.supersampling = 4;
    s.effects.emplace_back(psf);
    const RenderResult r = render_scene(s, layout, cam);
    // Independent prediction around each vertical-bar triplet: the exact
    // coverage on a fine grid, filtered in 2-D by the PSF's analytic
    // transfer and the pixel's box (sinc x sinc), sampled at pixel centres.
    // If the render matches it, the capture's transfer at every frequency,
    // m(f) included, is the analytic one.
    double worst = 0;
    int checked = 0;
    const int fine = 4, pad = 24;
    for (const ElementLayout& e : layout.elements) {
      if (e.orientation != BarOrientation::vertical_bars || e.bar_width_mm * kPxPerMm < 3) continue;
      const RectMm ext = e.extent_mm();
      const int x0 = int(std::floor(ext.x0 * kPxPerMm)) - pad, x1 = int(std::ceil(ext.x1 * kPxPerMm)) + pad;
      const int y0 = int(std::floor(ext.y0 * kPxPerMm)) - pad, y1 = int(std::ceil(ext.y1 * kPxPerMm)) + pad;
      const int nx = (x1 - x0) * fine, ny = (y1 - y0) * fine;
      cv::Mat g(ny, nx, CV_64F);
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) {
          // Pixel x covers [x, x + 1] / kPxPerMm in mm (target 0 at its corner).
          const RectMm cell{(x0 + double(i) / fine) / kPxPerMm, (y0 + double(j) / fine) / kPxPerMm,
                            (x0 + double(i + 1) / fine) / kPxPerMm, (y0 + double(j + 1) / fine) / kPxPerMm};
          double ink = 0;
          for (int k : index.query(cell)) ink += intersection_area_mm2(layout.artwork[k], cell);
          g.at<double>(j, i) = 1.0 - ink / cell.area_mm2();
        }
      cv::Mat spec;
      cv::dft(g, spec, cv::DFT_COMPLEX_OUTPUT);
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) {
          const double fx = double(i <= nx / 2 ? i : i - nx) * fine / nx;  // cycles per pixel
          const double fy = double(j <= ny / 2 ? j : j - ny) * fine / ny;
          auto sinc = [](double f) { return f == 0 ? 1.0 : std::sin(std::numbers::pi * f) / (std::numbers::pi * f); };
          spec.at<cv::Vec2d>(j, i) *= psf_mtf(psf, std::hypot(fx, fy)) * sinc(fx) * sinc(fy);
        }
      cv::Mat back;
      cv::dft(spec, back, cv::DFT_INVERSE | cv::DFT_SCALE | cv::DFT_REAL_OUTPUT);
      // Compare away from the window's wrapped border.
      for (int y = y0 + pad / 2; y < y1 - pad / 2; ++y)
        for (int x = x0 + pad / 2; x < x1 - pad / 2; ++x) {
          // Pixel centre x lies between fine cells k - 1 and k, k = (x - x0) * fine + fine / 2.
          const int i = (x - x0) * fine + fine / 2, j = (y - y0) * fine + fine / 2;
          const double predicted = 0.25 * (back.at<double>(j - 1, i - 1) + back.at<double>(j - 1, i) +
                                           back.at<double>(j, i - 1) + back.at<double>(j, i));
          worst = std::max(worst, std::abs(double(r.image.at<float>(y, x)) - predicted));
        }
      ++checked;
    }
    CAPTURE(std::string(to_string(psf.kind)));
    CHECK(checked >= 10);
    // Contrast is 1 (ink 0, ground 1): 0.01 of it bounds the error in m.
    CHECK(worst <= 0.01);
    MESSAGE(std::string(to_string(psf.kind)) << ": worst |render - analytic| = " << worst << " over " << checked << " triplets");
  }
}

TEST_CASE("simulate: the same seed gives the same bytes") {
  TempDir dir("seed");
  const auto layout_path = dir.path / "layout.json";
  write_layout_file(layout_path, default_layout());
  auto run = [&](const std::string& out, int seed) {
    const std::string cmd = std::string(TACTRES_BINARY) + " simulate " +
                            (source_dir() / "examples/scenes/cmos.json").string() + " --layout " +
                            layout_path.string() + " -o " + (dir.path / out).string() +
                            " --supersampling 1 --seed " + std::to_string(seed) + " > /dev/null";
    const int status = std::system(cmd.c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  };
  REQUIRE(run("a.png", 7) == 0);
  REQUIRE(run("b.png", 7) == 0);
  REQUIRE(run("c.png", 8) == 0);
  CHECK(read_file(dir.path / "a.png") == read_file(dir.path / "b.png"));
  CHECK(read_file(dir.path / "a.png") != read_file(dir.path / "c.png"));
}

TEST_CASE("simulate: a scene without a layout renders the default target of `tactres generate`, and says so") {
  TempDir dir("nolayout");
  const auto generated = dir.path / "target";
  REQUIRE(std::system((std::string(TACTRES_BINARY) + " generate --out " + generated.string() + " > /dev/null").c_str()) ==
          0);
  auto run = [&](const std::string& out, const std::string& extra) {
    const std::string cmd = std::string(TACTRES_BINARY) + " simulate " +
                            (source_dir() / "examples/scenes/cmos.json").string() + extra + " -o " +
                            (dir.path / out).string() + " --supersampling 1 > " + (dir.path / (out + ".txt")).string();
    const int status = std::system(cmd.c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  };
  REQUIRE(run("default.png", "") == 0);
  REQUIRE(run("given.png", " --layout " + (generated / "layout.json").string()) == 0);
  CHECK(read_file(dir.path / "default.png") == read_file(dir.path / "given.png"));
  CHECK(read_file(dir.path / "default.png.txt").find("layout: the default target") != std::string::npos);
  const auto truth = nlohmann::json::parse(read_file(dir.path / "default.png.truth.json"));
  CHECK(truth["layout"].get<std::string>().find("default target") != std::string::npos);
}

TEST_CASE("simulate: a lossy or 8-bit-only capture format is refused, and missing folders are made") {
  TempDir dir("formats");
  auto run = [&](const fs::path& out) {
    const std::string cmd = std::string(TACTRES_BINARY) + " simulate " +
                            (source_dir() / "examples/scenes/cmos.json").string() + " -o " + out.string() +
                            " --supersampling 1 > /dev/null 2> " + (dir.path / "err.txt").string();
    const int status = std::system(cmd.c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  };
  for (const char* name : {"a.jpg", "a.bmp", "a"}) {
    CAPTURE(name);
    CHECK(run(dir.path / name) == 3);
    CHECK(read_file(dir.path / "err.txt").find(".tif/.tiff or .exr") != std::string::npos);
  }
  // Nothing was written for the refused ones.
  for (const auto& e : fs::directory_iterator(dir.path)) CHECK(e.path().filename() == "err.txt");
  // The capture and its truth go into folders made for them.
  REQUIRE(run(dir.path / "new" / "folder" / "c.png") == 0);
  CHECK(fs::exists(dir.path / "new" / "folder" / "c.png"));
  CHECK(fs::exists(dir.path / "new" / "folder" / "c.png.truth.json"));
}

TEST_CASE("simulate: a scene with no element in view (the target behind the camera, or off the sensor) is refused") {
  TempDir dir("nothing-in-view");
  nlohmann::json scene = nlohmann::json::parse(read_file(source_dir() / "examples/scenes/cmos.json"));
  scene["camera"] = (source_dir() / "examples/cameras/wide_angle.cameramodel").string();
  for (const nlohmann::json& pose : {nlohmann::json{{"rt_camera_from_target", {0, 0, 0, 0, 0, -26}}},
                                     nlohmann::json{{"rt_camera_from_target", {0, 0, 0, 500, 0, 26}}}}) {
    CAPTURE(pose.dump());
    scene["pose"] = pose;
    write_file_atomically(dir.path / "scene.json", scene.dump());
    const std::string cmd = std::string(TACTRES_BINARY) + " simulate " + (dir.path / "scene.json").string() +
                            " -o " + (dir.path / "c.png").string() + " > /dev/null 2> " +
                            (dir.path / "err.txt").string();
    const int status = std::system(cmd.c_str());
    CHECK((WIFEXITED(status) && WEXITSTATUS(status) == 3));
    CHECK(read_file(dir.path / "err.txt").find("no element of the target in full view") != std::string::npos);
    CHECK_FALSE(fs::exists(dir.path / "c.png"));
  }
}
