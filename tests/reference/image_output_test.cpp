// Unit tests of the files the renderer writes: plain PNGs with no colour
// chunk, exact values, and a float TIFF.
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>

#include <OpenImageIO/imageio.h>
#include <doctest/doctest.h>

#include "reference_renderer.h"

using namespace reference;
namespace fs = std::filesystem;

namespace {

// The chunk types of a PNG file, in order.
std::vector<std::string> png_chunks(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  const std::vector<unsigned char> d((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  REQUIRE(d.size() > 8);
  REQUIRE(d[1] == 'P');
  std::vector<std::string> types;
  for (size_t i = 8; i + 8 <= d.size();) {
    const std::uint32_t n = (std::uint32_t(d[i]) << 24) | (d[i + 1] << 16) | (d[i + 2] << 8) | d[i + 3];
    types.emplace_back(reinterpret_cast<const char*>(&d[i + 4]), 4);
    i += 12 + n;
  }
  return types;
}

Image ramp(int width_px, int height_px) {
  Image im;
  im.width_px = width_px;
  im.height_px = height_px;
  for (int y = 0; y < height_px; ++y)
    for (int x = 0; x < width_px; ++x) im.values.push_back(static_cast<float>((x + width_px * y) / 65535.0));
  return im;
}

std::vector<float> read_back(const fs::path& path, OIIO::ImageSpec& spec) {
  auto in = OIIO::ImageInput::open(path.string());
  REQUIRE(in);
  spec = in->spec();
  std::vector<float> v(static_cast<size_t>(spec.width) * spec.height * spec.nchannels);
  REQUIRE(in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, v.data()));
  return v;
}

}  // namespace

TEST_CASE("renderer: PNGs carry no colour chunk (gAMA, sRGB, iCCP, cHRM) and exact linear values") {
  const fs::path dir = fs::temp_directory_path() / ("reference_png_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const Image im = ramp(256, 4);
  for (const char* format : {"png16", "png8"}) {
    CAPTURE(format);
    const fs::path p = dir / (std::string(format) + ".png");
    write_image(p.string(), im, format);
    const auto chunks = png_chunks(p);
    const std::set<std::string> types(chunks.begin(), chunks.end());
    for (const char* colour : {"gAMA", "sRGB", "iCCP", "cHRM"}) CHECK(types.count(colour) == 0);
    CHECK(chunks.front() == "IHDR");
    CHECK(chunks.back() == "IEND");
    OIIO::ImageSpec spec;
    const std::vector<float> v = read_back(p, spec);
    CHECK(spec.width == 256);
    CHECK(spec.nchannels == 1);
    CHECK(spec.format == (std::string(format) == "png16" ? OIIO::TypeDesc::UINT16 : OIIO::TypeDesc::UINT8));
    // 16-bit: value k / 65535 reads back as k / 65535 exactly; 8-bit: to the nearest 1/255.
    const double tol = std::string(format) == "png16" ? 1e-7 : 0.5 / 255 + 1e-7;
    double worst = 0;
    for (size_t i = 0; i < v.size(); ++i) worst = std::max(worst, std::abs(double(v[i]) - im.values[i]));
    CHECK(worst <= tol);
  }
  fs::remove_all(dir);
}

TEST_CASE("renderer: 32-bit float TIFF keeps values as they are, out-of-range and negative included") {
  const fs::path p = fs::temp_directory_path() / ("reference_tiff_test_" + std::to_string(::getpid()) + ".tif");
  Image im = ramp(64, 3);
  im.values[5] = -0.25f;
  im.values[7] = 1.5f;
  write_image(p.string(), im);  // .tif -> tiff32f
  OIIO::ImageSpec spec;
  const std::vector<float> v = read_back(p, spec);
  CHECK(spec.format == OIIO::TypeDesc::FLOAT);
  CHECK(spec.get_string_attribute("oiio:ColorSpace") != "sRGB");
  REQUIRE(v.size() == im.values.size());
  CHECK(v == im.values);
  fs::remove(p);
}

TEST_CASE("renderer: quantisation clips to the 0..1 range and rounds to nearest") {
  const fs::path p = fs::temp_directory_path() / ("reference_clip_test_" + std::to_string(::getpid()) + ".png");
  Image im;
  im.width_px = 4;
  im.height_px = 1;
  im.values = {-0.1f, 1.7f, 0.5f, 1.0f / 65535 * 0.49f};
  write_image(p.string(), im, "png16");
  OIIO::ImageSpec spec;
  const std::vector<float> v = read_back(p, spec);
  CHECK(v[0] == 0.0f);
  CHECK(v[1] == 1.0f);
  CHECK(v[2] == doctest::Approx(32768.0 / 65535));
  CHECK(v[3] == 0.0f);
  fs::remove(p);
}
