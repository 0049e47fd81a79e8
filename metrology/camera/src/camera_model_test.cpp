#include "tactres/camera/camera_model.h"

#include <doctest/doctest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <random>
#include <string>

#include "tactres/util/atomic_file.h"

namespace tactres {
namespace {

namespace fs = std::filesystem;

const fs::path kExamples = fs::path(TACTRES_SOURCE_DIR) / "examples" / "cameras";

// The generator of the shipped example models (examples/cameras/README.md
// explains the numbers). Every value has at most 6 decimals because mrcal
// writes with "%f": the shipped file then reloads to exactly these values.
CameraModel make_example_wide_angle() {
  return CameraModel::from_lens("LENSMODEL_OPENCV8",
                                {560.0, 560.0, 641.3, 357.9,           // fx fy cx cy
                                 -0.3, 0.1, 0.0004, -0.0003, -0.005,  // k1 k2 p1 p2 k3
                                 0.0, 0.0, 0.0},                       // k4 k5 k6
                                1280, 720);
}

CameraModel make_example_pinhole() { return CameraModel::pinhole(560.0, 560.0, 639.5, 359.5, 1280, 720); }

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() /
           ("tactres_camera_test_" + std::to_string(std::random_device{}()));
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

std::string throws_message_invalid(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "<no std::invalid_argument>";
}

}  // namespace

TEST_CASE("shipped example camera models are exactly what the generator writes") {
  // Set TACTRES_REGENERATE_EXAMPLES=1 to rewrite examples/cameras/ from the
  // generator above (then review the diff and commit it).
  if (const char* regen = std::getenv("TACTRES_REGENERATE_EXAMPLES"); regen && std::string(regen) == "1") {
    make_example_wide_angle().save(kExamples / "wide_angle.cameramodel");
    make_example_pinhole().save(kExamples / "pinhole.cameramodel");
  }
  TempDir tmp;
  make_example_wide_angle().save(tmp.path / "wide_angle.cameramodel");
  make_example_pinhole().save(tmp.path / "pinhole.cameramodel");
  for (const char* name : {"wide_angle.cameramodel", "pinhole.cameramodel"}) {
    CAPTURE(name);
    CHECK(read_file(kExamples / name) == read_file(tmp.path / name));
  }
}

TEST_CASE("example models load with the documented parameters and survive a save/load round trip") {
  const CameraModel wide = CameraModel::load(kExamples / "wide_angle.cameramodel");
  CHECK(wide.lensmodel_name() == "LENSMODEL_OPENCV8");
  CHECK(wide.imager_width() == 1280);
  CHECK(wide.imager_height() == 720);
  CHECK_FALSE(wide.is_pinhole());
  REQUIRE(wide.num_intrinsics() == 12);
  CHECK(wide.intrinsics() == make_example_wide_angle().intrinsics());
  CHECK(wide.source() == (kExamples / "wide_angle.cameramodel").string());

  const CameraModel pin = CameraModel::load(kExamples / "pinhole.cameramodel");
  CHECK(pin.lensmodel_name() == "LENSMODEL_PINHOLE");
  CHECK(pin.is_pinhole());
  CHECK(pin.intrinsics() == std::vector<double>{560.0, 560.0, 639.5, 359.5});

  TempDir tmp;
  for (const CameraModel* m : {&wide, &pin}) {
    const fs::path p = tmp.path / "copy.cameramodel";
    m->save(p);
    const CameraModel back = CameraModel::load(p);
    CHECK(back.lensmodel_name() == m->lensmodel_name());
    CHECK(back.imager_width() == m->imager_width());
    CHECK(back.imager_height() == m->imager_height());
    CHECK(back.intrinsics() == m->intrinsics());
    // No temporary file is left beside the output.
    int files = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator(tmp.path)) ++files;
    CHECK(files == 1);
  }
}

TEST_CASE("save rounds to mrcal's 6 decimals, as documented") {
  TempDir tmp;
  const CameraModel m = CameraModel::pinhole(560.123456789, 561.0, 639.5, 359.5, 1280, 720);
  m.save(tmp.path / "m.cameramodel");
  const double fx = CameraModel::load(tmp.path / "m.cameramodel").intrinsics()[0];
  CHECK(std::abs(fx - 560.123456789) <= 5e-7);
}

TEST_CASE("load reports unreadable and malformed files with the path and the problem") {
  TempDir tmp;
  const fs::path missing = tmp.path / "nope.cameramodel";
  try {
    CameraModel::load(missing);
    FAIL("no exception");
  } catch (const std::runtime_error& e) {
    CHECK(std::string(e.what()).find(missing.string()) != std::string::npos);
  }

  auto write = [&](const std::string& name, const std::string& text) {
    const fs::path p = tmp.path / name;
    std::ofstream(p) << text;
    return p;
  };
  struct Case {
    const char* name;
    std::string text;
    const char* expect;
  };
  const Case cases[] = {
      {"empty.cameramodel", "", "empty"},
      {"nokey.cameramodel", "{ 'lensmodel': 'LENSMODEL_PINHOLE', 'intrinsics': [1,1,1,1] }",
       "'imagersize' is missing"},
      {"badlens.cameramodel",
       "{ 'lensmodel': 'LENSMODEL_FISHEYE9', 'intrinsics': [1,1,1,1], 'imagersize': [10,10], "
       "'extrinsics': [0,0,0,0,0,0] }",
       "unknown or incompletely configured lens model 'LENSMODEL_FISHEYE9'"},
      {"count.cameramodel",
       "{ 'lensmodel': 'LENSMODEL_OPENCV8', 'intrinsics': [1,1,1,1,0,0], 'imagersize': [10,10], "
       "'extrinsics': [0,0,0,0,0,0] }",
       "LENSMODEL_OPENCV8 needs 12 intrinsics but the file lists 6"},
      {"focal.cameramodel",
       "{ 'lensmodel': 'LENSMODEL_PINHOLE', 'intrinsics': [-500,500,5,5], 'imagersize': [10,10], "
       "'extrinsics': [0,0,0,0,0,0] }",
       "focal lengths fx, fy must be positive"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.name);
    const fs::path p = write(c.name, c.text);
    const std::string msg = throws_message_invalid([&] { CameraModel::load(p); });
    CHECK(msg.find(p.string()) != std::string::npos);
    CHECK(msg.find(c.expect) != std::string::npos);
  }
}

TEST_CASE("check_image_size names the model, both sizes and the remedy") {
  const CameraModel m = CameraModel::parse(read_file(kExamples / "wide_angle.cameramodel"), "cam.cameramodel");
  CHECK_NOTHROW(m.check_image_size(1280, 720));
  CHECK(throws_message_invalid([&] { m.check_image_size(640, 480); }) ==
        "camera model cam.cameramodel is for a 1280x720 imager but the image is 640x480: use the "
        "model calibrated for this camera, or resize/crop consistently");
  CHECK_THROWS_AS(m.check_image_size(720, 1280), std::invalid_argument);
}

TEST_CASE("constructors reject bad parameters") {
  CHECK_THROWS_AS(CameraModel::pinhole(0.0, 500, 320, 240, 640, 480), std::invalid_argument);
  CHECK_THROWS_AS(CameraModel::pinhole(500, 500, NAN, 240, 640, 480), std::invalid_argument);
  CHECK_THROWS_AS(CameraModel::pinhole(500, 500, 320, 240, 0, 480), std::invalid_argument);
  CHECK(throws_message_invalid([] { CameraModel::from_lens("LENSMODEL_OPENCV4", {1, 1, 1, 1}, 10, 10); })
            .find("LENSMODEL_OPENCV4 needs 8 intrinsics") != std::string::npos);
  CHECK(throws_message_invalid([] { CameraModel::from_lens("LENSMODEL_NOPE", {1, 1, 1, 1}, 10, 10); })
            .find("mrcal supports: LENSMODEL_PINHOLE") != std::string::npos);
}

TEST_CASE("copies are independent of the original") {
  std::optional<CameraModel> a = make_example_wide_angle();
  const CameraModel b = *a;
  CameraModel c = CameraModel::pinhole(100, 100, 5, 5, 10, 10);
  c = *a;
  a.reset();
  CHECK(b.intrinsics() == make_example_wide_angle().intrinsics());
  CHECK(c.lensmodel_name() == "LENSMODEL_OPENCV8");
}

TEST_CASE("wide-angle example: unproject then project returns every pixel within 1e-6 px") {
  const CameraModel m = CameraModel::load(kExamples / "wide_angle.cameramodel");
  std::vector<Vec2> px;
  for (int y = 0; y <= 720; y += 10)
    for (int x = 0; x <= 1280; x += 10)
      px.push_back({double(std::min(x, 1279)), double(std::min(y, 719))});
  // Include the exact corners and the pixel-edge extremes.
  for (Vec2 c : {Vec2{-0.5, -0.5}, Vec2{1279.5, -0.5}, Vec2{-0.5, 719.5}, Vec2{1279.5, 719.5}})
    px.push_back(c);
  const auto rays = m.unproject(px);
  std::vector<Vec3> pts;
  for (std::size_t i = 0; i < px.size(); ++i) {
    REQUIRE(rays[i].has_value());
    CHECK(std::abs(std::hypot(rays[i]->x, rays[i]->y, rays[i]->z) - 1.0) < 1e-12);
    // Any point along the ray projects to the same pixel.
    pts.push_back({25.0 * rays[i]->x, 25.0 * rays[i]->y, 25.0 * rays[i]->z});
  }
  const auto back = m.project(pts);
  double worst = 0.0;
  for (std::size_t i = 0; i < px.size(); ++i) {
    REQUIRE(back[i].valid);
    worst = std::max(worst, norm(back[i].px - px[i]));
  }
  CHECK(worst < 1e-6);
}

TEST_CASE("wide-angle example: visible barrel distortion, monotonic over the whole imager") {
  const CameraModel m = make_example_wide_angle();
  const CameraModel ideal = CameraModel::pinhole(560.0, 560.0, 641.3, 357.9, 1280, 720);
  // Barrel: a corner pixel looks along a ray far outside the pinhole's corner.
  const Vec2 corner{1279.0, 719.0};
  const auto ray = m.unproject(std::span<const Vec2>(&corner, 1))[0];
  REQUIRE(ray.has_value());
  const auto pin = ideal.project(std::span<const Vec3>(&*ray, 1))[0];
  REQUIRE(pin.valid);
  CHECK(norm(pin.px - corner) > 100.0);

  // Monotonic: the Jacobian of pixels w.r.t. normalised coordinates (x/z,
  // y/z) keeps a positive determinant everywhere on (and just beyond) the
  // imager, so the lens never folds back.
  std::vector<Vec2> px;
  for (double y = -2; y <= 722; y += 6)
    for (double x = -2; x <= 1282; x += 6) px.push_back({x, y});
  const auto rays = m.unproject(px);
  std::vector<Vec3> normalised;
  for (const auto& r : rays) {
    REQUIRE(r.has_value());
    REQUIRE(r->z > 0.0);
    normalised.push_back({r->x / r->z, r->y / r->z, 1.0});
  }
  double min_det = 1e300;
  for (const auto& g : m.project_with_gradient(normalised)) {
    REQUIRE(g.valid);
    const double det = g.dpx_dpoint[0] * g.dpx_dpoint[4] - g.dpx_dpoint[1] * g.dpx_dpoint[3];
    min_det = std::min(min_det, det);
  }
  // Pinhole: 560^2 = 313600. Barrel squeezes, but stays well away from zero.
  CHECK(min_det > 0.2 * 560.0 * 560.0);
  CHECK(min_det < 0.9 * 560.0 * 560.0);
}

TEST_CASE("points behind the camera are reported invalid") {
  for (const CameraModel& m : {make_example_wide_angle(), make_example_pinhole()}) {
    const std::vector<Vec3> p = {{1, 2, 30}, {1, 2, 0}, {1, 2, -30}, {0, 0, -1}};
    const auto q = m.project(p);
    CHECK(q[0].valid);
    CHECK_FALSE(q[1].valid);
    CHECK_FALSE(q[2].valid);
    CHECK_FALSE(q[3].valid);
    std::vector<Vec2> out(p.size());
    CHECK_FALSE(m.project_into(p, out, {}, {}, {}));
  }
}

TEST_CASE("project_with_gradient agrees with central differences") {
  const CameraModel m = make_example_wide_angle();
  const std::vector<Vec3> pts = {{0, 0, 26}, {9, -7, 26}, {-14, 11, 24}, {20, 12, 22}};
  const auto g = m.project_with_gradient(pts);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    REQUIRE(g[i].valid);
    for (int c = 0; c < 3; ++c) {
      const double h = 1e-5;
      Vec3 a = pts[i], b = pts[i];
      (c == 0 ? a.x : c == 1 ? a.y : a.z) += h;
      (c == 0 ? b.x : c == 1 ? b.y : b.z) -= h;
      const Vec2 qa = m.project(std::span<const Vec3>(&a, 1))[0].px;
      const Vec2 qb = m.project(std::span<const Vec3>(&b, 1))[0].px;
      CHECK(g[i].dpx_dpoint[c] == doctest::Approx((qa.x - qb.x) / (2 * h)).epsilon(1e-6));
      CHECK(g[i].dpx_dpoint[3 + c] == doctest::Approx((qa.y - qb.y) / (2 * h)).epsilon(1e-6));
    }
  }
}

}  // namespace tactres
