#include <filesystem>
#include <random>

#include <OpenImageIO/imageio.h>
#include <doctest/doctest.h>

#include "tactres/targets/heightmap.h"

using namespace tactres;
namespace fs = std::filesystem;

TEST_CASE("height map: float TIFF in mm integrates to the raised volume") {
  LayoutOptions o;
  o.relief_height_mm = 0.25;
  const TargetLayout L = make_layout(o);
  const double ppm = 25.0;
  const ImageF c = coverage_raster(L, ppm);
  const fs::path dir = fs::temp_directory_path() /
                       ("tactres-height-test-" + std::to_string(std::random_device{}()));
  fs::create_directories(dir);
  write_height_map_tiff(dir / "h.tif", L, c, ppm);

  auto in = OIIO::ImageInput::open((dir / "h.tif").string());
  REQUIRE(in);
  CHECK(in->spec().format == OIIO::TypeDesc::FLOAT);
  CHECK(in->spec().nchannels == 1);
  CHECK(in->spec().width == c.width);
  std::vector<float> h(c.pixels.size());
  REQUIRE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::FLOAT, h.data()));
  in->close();
  fs::remove_all(dir);

  double volume = 0;
  float top = 0;
  for (float v : h) {
    volume += v / (ppm * ppm);
    top = std::max(top, v);
  }
  CHECK(top == doctest::Approx(0.25).epsilon(1e-6));  // the patch is fully raised
  CHECK(volume == doctest::Approx(L.inked_area_mm2() * 0.25).epsilon(1e-6));
  CHECK(h[0] == 0.0f);  // the corner is ground
}
