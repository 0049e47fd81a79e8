#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <random>

#include <OpenImageIO/imageio.h>
#include <doctest/doctest.h>

#include "tactres/targets/raster.h"

using namespace tactres;
namespace fs = std::filesystem;

namespace {

double summed(const ImageF& img) {
  double s = 0;
  for (float v : img.pixels) s += v;
  return s;
}

TargetLayout tiny_layout(ArtworkShape s) {
  TargetLayout L;
  L.width_mm = 1.0;
  L.height_mm = 1.0;
  L.artwork = {std::move(s)};
  return L;
}

fs::path fresh_dir(const char* name) {
  const fs::path d = fs::temp_directory_path() /
                     (std::string(name) + "-" + std::to_string(std::random_device{}()));
  fs::create_directories(d);
  return d;
}

}  // namespace

TEST_CASE("raster: size is ceil(size * px/mm), resolution is validated") {
  CHECK(raster_size_px(20, 40) == 800);
  CHECK(raster_size_px(20, 37.5) == 750);
  CHECK(raster_size_px(20, 40.1) == 802);
  CHECK(raster_size_px(20, 40.12) == 803);
  const TargetLayout L = make_layout({});
  CHECK_THROWS_AS(coverage_raster(L, 0.0), std::invalid_argument);
  CHECK_THROWS_AS(coverage_raster(L, -3.0), std::invalid_argument);
  CHECK_THROWS_AS(coverage_raster(L, 2000.5), std::invalid_argument);
  CHECK_THROWS_AS(coverage_raster(L, NAN), std::invalid_argument);
  LayoutOptions big;
  big.field_width_mm = big.field_height_mm = 500;
  CHECK_THROWS_WITH_AS(validate_raster_resolution(make_layout(big), 2000),
                       doctest::Contains("px/mm"), std::invalid_argument);
}

TEST_CASE("raster: summed coverage equals the inked area of the default target") {
  const TargetLayout L = make_layout({});
  for (double ppm : {40.0, 37.5, 13.0, 7.3}) {
    const ImageF c = coverage_raster(L, ppm);
    CHECK(c.width == raster_size_px(20, ppm));
    const double area = summed(c) / (ppm * ppm);
    INFO("px/mm = " << ppm);
    CHECK(std::abs(area / L.inked_area_mm2() - 1) < 1e-6);
    const auto [lo, hi] = std::minmax_element(c.pixels.begin(), c.pixels.end());
    CHECK(*lo == 0.0f);
    CHECK(*hi == 1.0f);
  }
}

TEST_CASE("raster: a rect at non-integer pixel edges gives the analytic pixel values") {
  ArtworkShape r;
  r.kind = ArtworkShape::Kind::rect;
  r.rect_mm = {0.25, 0.13, 0.47, 0.30};
  const ImageF c = coverage_raster(tiny_layout(r), 10.0);  // 0.1 mm pixels
  REQUIRE(c.width == 10);
  REQUIRE(c.height == 10);
  // Columns 2, 3, 4 are covered 0.5, 1, 0.7; rows 1, 2 are covered 0.7, 1.
  const double col[10] = {0, 0, 0.5, 1, 0.7, 0, 0, 0, 0, 0};
  const double row[10] = {0, 0.7, 1, 0, 0, 0, 0, 0, 0, 0};
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 10; ++x) {
      INFO("pixel " << x << "," << y);
      CHECK(c.at(x, y) == doctest::Approx(col[x] * row[y]).epsilon(1e-6));
    }
}

TEST_CASE("raster: a disc centred on a pixel corner splits evenly over four pixels") {
  ArtworkShape d;
  d.kind = ArtworkShape::Kind::disc;
  d.center_mm = {0.5, 0.3};
  d.radius_mm = 0.04;
  const ImageF c = coverage_raster(tiny_layout(d), 10.0);
  const double quarter = std::numbers::pi * 0.04 * 0.04 / 4 * 100;  // per 0.01 mm^2 pixel
  CHECK(c.at(4, 2) == doctest::Approx(quarter).epsilon(1e-6));
  CHECK(c.at(5, 2) == doctest::Approx(quarter).epsilon(1e-6));
  CHECK(c.at(4, 3) == doctest::Approx(quarter).epsilon(1e-6));
  CHECK(c.at(5, 3) == doctest::Approx(quarter).epsilon(1e-6));
  CHECK(summed(c) == doctest::Approx(4 * quarter).epsilon(1e-6));
}

TEST_CASE("raster: PNG 8-bit and TIFF 16-bit carry the polarity and leave no temp file") {
  const fs::path dir = fresh_dir("tactres-raster-test");
  ArtworkShape r;
  r.kind = ArtworkShape::Kind::rect;
  r.rect_mm = {0.2, 0.2, 0.6, 0.6};
  const TargetLayout L = tiny_layout(r);
  const ImageF c = coverage_raster(L, 10.0);
  write_target_png8(dir / "t.png", c, Polarity::dark_bars_on_light, 10.0);
  write_target_tiff16(dir / "t.tif", c, Polarity::light_bars_on_dark, 10.0);
  CHECK(std::distance(fs::directory_iterator(dir), fs::directory_iterator{}) == 2);

  auto read = [](const fs::path& p, OIIO::TypeDesc want) {
    auto in = OIIO::ImageInput::open(p.string());
    REQUIRE(in);
    const OIIO::ImageSpec& spec = in->spec();
    CHECK(spec.width == 10);
    CHECK(spec.nchannels == 1);
    CHECK(spec.format == want);
    std::vector<float> px(size_t(spec.width * spec.height));
    REQUIRE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::FLOAT, px.data()));
    return px;
  };
  const auto png = read(dir / "t.png", OIIO::TypeDesc::UINT8);
  CHECK(png[0] == 1.0f);         // ground is light
  CHECK(png[3 * 10 + 3] == 0.0f);  // ink is dark
  const auto tif = read(dir / "t.tif", OIIO::TypeDesc::UINT16);
  CHECK(tif[0] == 0.0f);
  CHECK(tif[3 * 10 + 3] == 1.0f);
  fs::remove_all(dir);

  CHECK_THROWS_AS(write_target_png8(dir / "missing" / "t.png", c, Polarity::dark_bars_on_light, 10),
                  std::runtime_error);
}
