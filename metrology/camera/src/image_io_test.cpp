// The pixel-encoding policy of load_image (docs/CONVENTIONS.md, "Pixels
// in"), on files written by OpenImageIO with and without colour tags.
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <OpenImageIO/imageio.h>
#include <doctest/doctest.h>
#include <opencv2/core.hpp>

#include "tactres/camera/image_io.h"

using namespace tactres;
namespace fs = std::filesystem;

namespace {

struct TempFolder {
  fs::path path = fs::temp_directory_path() / ("tactres-image-io-" + std::to_string(::getpid()));
  TempFolder() { fs::create_directories(path); }
  ~TempFolder() { fs::remove_all(path); }
};

// A 4x4 grey image whose every pixel holds `code` (in [0, 1]), with the
// given OpenImageIO colour attributes (none: an untagged file).
fs::path write_grey(const fs::path& file, OIIO::TypeDesc type, float code, const std::string& colour_space = "",
                    float gamma = 0) {
  auto out = OIIO::ImageOutput::create(file.string());
  REQUIRE(out);
  OIIO::ImageSpec spec(4, 4, 1, type);
  if (!colour_space.empty()) spec.attribute("oiio:ColorSpace", colour_space);
  if (gamma > 0) spec.attribute("oiio:Gamma", gamma);
  REQUIRE(out->open(file.string(), spec));
  const float pixels[16] = {code, code, code, code, code, code, code, code,
                            code, code, code, code, code, code, code, code};
  REQUIRE(out->write_image(OIIO::TypeDesc::FLOAT, pixels));
  REQUIRE(out->close());
  return file;
}

float srgb_decoded(float v) { return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f); }

// A TIFF of one 8-bit grey image per size in `pages`, each of code 100.
fs::path write_pages(const fs::path& file, const std::vector<int>& pages) {
  auto out = OIIO::ImageOutput::create(file.string());
  REQUIRE(out);
  std::vector<OIIO::ImageSpec> specs;
  for (int side : pages) specs.emplace_back(side, side, 1, OIIO::TypeDesc::UINT8);
  REQUIRE(out->open(file.string(), static_cast<int>(specs.size()), specs.data()));
  for (size_t page = 0; page < specs.size(); ++page) {
    if (page > 0) REQUIRE(out->open(file.string(), specs[page], OIIO::ImageOutput::AppendSubimage));
    const std::vector<unsigned char> pixels(size_t(specs[page].width) * specs[page].height, 100);
    REQUIRE(out->write_image(OIIO::TypeDesc::UINT8, pixels.data()));
  }
  REQUIRE(out->close());
  return file;
}

// Stored 3 x 2 float, value 1 + 10 y + x, with the given Orientation tag.
constexpr int kOrientedW = 3, kOrientedH = 2;
constexpr float kOrientedPixels[kOrientedW * kOrientedH] = {1, 2, 3, 11, 12, 13};
fs::path write_oriented(const fs::path& file, int orientation) {
  auto out = OIIO::ImageOutput::create(file.string());
  REQUIRE(out);
  OIIO::ImageSpec spec(kOrientedW, kOrientedH, 1, OIIO::TypeDesc::FLOAT);
  spec.attribute("Orientation", orientation);
  REQUIRE(out->open(file.string(), spec));
  REQUIRE(out->write_image(OIIO::TypeDesc::FLOAT, kOrientedPixels));
  REQUIRE(out->close());
  return file;
}

}  // namespace

TEST_CASE("transfer curves: names, options, round trips, and the odd extension below 0") {
  CHECK(TransferCurve::linear().name() == "linear");
  CHECK(TransferCurve::srgb().option() == "--transfer srgb");
  CHECK(TransferCurve::power(2.2).name() == "gamma 2.2");
  CHECK(TransferCurve::power(1.004).name() == "linear");  // close enough to 1 is linear
  CHECK_FALSE(transfer_from_option("auto").has_value());
  CHECK(transfer_from_option("gamma:1.8")->gamma == doctest::Approx(1.8));
  CHECK_THROWS_AS(transfer_from_option("gamma:"), std::invalid_argument);
  CHECK_THROWS_AS(transfer_from_option("gamma:9"), std::invalid_argument);
  CHECK_THROWS_AS(transfer_from_option("sRGB2"), std::invalid_argument);
  for (const TransferCurve& c : {TransferCurve::linear(), TransferCurve::srgb(), TransferCurve::power(2.4)})
    for (float v : {-0.3f, 0.0f, 0.002f, 0.2f, 0.5f, 1.0f, 1.7f}) {
      CAPTURE(c.name());
      CAPTURE(v);
      CHECK(c.to_code(c.to_linear(v)) == doctest::Approx(v).epsilon(1e-5));
    }
  CHECK(TransferCurve::srgb().to_linear(0.5f) == doctest::Approx(0.21404).epsilon(1e-4));
  CHECK(TransferCurve::srgb().to_linear(-0.5f) == doctest::Approx(-0.21404).epsilon(1e-4));
  CHECK(std::isnan(TransferCurve::power(2.2).to_linear(NAN)));
}

TEST_CASE("decide_transfer: forced, then the file's tag, then the bit depth") {
  const ColourTag none;
  const ColourTag srgb_tag{true, TransferCurve::srgb(), "PNG sRGB chunk"};
  CHECK(decide_transfer(TransferCurve::linear(), srgb_tag, true, 8).curve.name() == "linear");
  CHECK(decide_transfer(TransferCurve::linear(), srgb_tag, true, 8).reason == "forced by --transfer linear");
  CHECK(decide_transfer(std::nullopt, srgb_tag, true, 16).curve.name() == "srgb");
  CHECK_FALSE(decide_transfer(std::nullopt, srgb_tag, true, 16).guessed);
  const TransferDecision d8 = decide_transfer(std::nullopt, none, true, 8);
  CHECK(d8.curve.name() == "srgb");
  CHECK(d8.reason == "8-bit, no colour tag");
  CHECK(d8.guessed);
  const TransferDecision d16 = decide_transfer(std::nullopt, none, true, 16);
  CHECK(d16.curve.name() == "linear");
  CHECK(d16.reason == "16-bit, no colour tag");
  CHECK(decide_transfer(std::nullopt, none, false, 32).reason == "float, no colour tag");
}

TEST_CASE("load_image: untagged files follow the bit depth, tagged files follow their tag") {
  TempFolder dir;
  const float code = 0.5f;
  const float as_srgb = srgb_decoded(code);
  struct Case {
    std::string file;
    OIIO::TypeDesc type;
    std::string colour_space;
    float gamma;
    std::string curve;
    std::string reason_has;
  };
  const Case cases[] = {
      {"untagged16.png", OIIO::TypeDesc::UINT16, "", 0, "linear", "16-bit, no colour tag"},
      {"untagged8.png", OIIO::TypeDesc::UINT8, "", 0, "srgb", "8-bit, no colour tag"},
      {"srgb16.png", OIIO::TypeDesc::UINT16, "sRGB", 0, "srgb", "PNG sRGB chunk"},
      {"linear8.png", OIIO::TypeDesc::UINT8, "Linear", 0, "linear", "PNG gAMA chunk"},
      {"gamma16.png", OIIO::TypeDesc::UINT16, "GammaCorrected2.2", 2.2f, "gamma 2.2", "PNG gAMA chunk"},
      {"untagged16.tif", OIIO::TypeDesc::UINT16, "", 0, "linear", "16-bit, no colour tag"},
      {"untagged8.tif", OIIO::TypeDesc::UINT8, "", 0, "srgb", "8-bit, no colour tag"},
      {"srgb16.tif", OIIO::TypeDesc::UINT16, "sRGB", 0, "srgb", "EXIF ColorSpace sRGB"},
      {"float.tif", OIIO::TypeDesc::FLOAT, "", 0, "linear", "float, no colour tag"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.file);
    const fs::path file = write_grey(dir.path / c.file, c.type, code, c.colour_space, c.gamma);
    const LoadedImage img = load_image(file);
    CHECK(img.transfer.curve.name() == c.curve);
    CHECK(img.transfer.reason.find(c.reason_has) != std::string::npos);
    const float expected = c.curve == "srgb" ? as_srgb : c.curve == "linear" ? code : std::pow(code, 2.2f);
    // 8-bit codes are 1/255 steps: 0.5 is stored as 128/255.
    const double tolerance = c.type == OIIO::TypeDesc::UINT8 ? 0.005 : 1e-4;
    CHECK(std::abs(img.luminance.at<float>(1, 1) - expected) <= tolerance);
    // Forcing the other reading changes the values, and says so.
    LoadOptions forced;
    forced.transfer = c.curve == "linear" ? TransferCurve::srgb() : TransferCurve::linear();
    const LoadedImage other = load_image(file, forced);
    CHECK(other.transfer.reason.rfind("forced by --transfer", 0) == 0);
    CHECK(std::abs(other.luminance.at<float>(1, 1) - img.luminance.at<float>(1, 1)) > 0.05);
  }
}

TEST_CASE("load_image: an integer file's code rounding is its noise floor, in linear light at each level") {
  TempFolder dir;
  const double sqrt12 = std::sqrt(12.0);
  // 16-bit linear: one step of 1/65535 everywhere.
  const LoadedImage lin16 = load_image(write_grey(dir.path / "lin16.png", OIIO::TypeDesc::UINT16, 0.5f));
  CHECK(lin16.rounding.sd_at(0.01) == doctest::Approx(1.0 / 65535 / sqrt12).epsilon(0.01));
  CHECK(lin16.rounding.sd_at(0.9) == doctest::Approx(1.0 / 65535 / sqrt12).epsilon(0.01));
  // 8-bit sRGB: the step in light grows with the level (the curve's slope):
  // 1/255/12.92 on the linear toe, the curve's slope at mid grey.
  const LoadedImage srgb8 = load_image(write_grey(dir.path / "srgb8.png", OIIO::TypeDesc::UINT8, 0.5f));
  CHECK(srgb8.rounding.sd_at(0.001) == doctest::Approx(1.0 / 255 / 12.92 / sqrt12).epsilon(0.02));
  const double mid = srgb_decoded(128 / 255.0f), step_mid = srgb_decoded(128.5f / 255) - srgb_decoded(127.5f / 255);
  CHECK(srgb8.rounding.sd_at(mid) == doctest::Approx(step_mid / sqrt12).epsilon(0.02));
  CHECK(srgb8.rounding.sd_at(0.9) > 5 * srgb8.rounding.sd_at(0.001));
  // Signed 16-bit: half a step of [-1, 1], offset to [0, 1].
  const LoadedImage signed16 = load_image(write_grey(dir.path / "s16.tif", OIIO::TypeDesc::INT16, 0.0f));
  CHECK(signed16.rounding.sd_at(0.5) == doctest::Approx(0.5 / 32767 / sqrt12).epsilon(0.01));
  // A 12-bit TIFF (in a 16-bit container, stretched to its range when
  // read): its own step, 1/4095.
  {
    const fs::path file = dir.path / "twelve.tif";
    auto out = OIIO::ImageOutput::create(file.string());
    REQUIRE(out);
    OIIO::ImageSpec spec(4, 4, 1, OIIO::TypeDesc::UINT16);
    spec.attribute("oiio:BitsPerSample", 12);
    REQUIRE(out->open(file.string(), spec));
    const std::vector<float> pixels(16, 0.5f);
    REQUIRE(out->write_image(OIIO::TypeDesc::FLOAT, pixels.data()));
    REQUIRE(out->close());
    const LoadedImage twelve = load_image(file);
    REQUIRE(twelve.bits_per_sample == 12);
    CHECK(twelve.rounding.sd_at(0.5) == doctest::Approx(1.0 / 4095 / sqrt12).epsilon(0.01));
  }
  // 32-bit integers: a step below float's resolution still reads its size.
  const LoadedImage u32 = load_image(write_grey(dir.path / "u32.tif", OIIO::TypeDesc::UINT32, 0.5f));
  CHECK(u32.rounding.sd_at(0.5) == doctest::Approx(1.0 / 4294967295.0 / sqrt12).epsilon(0.01));
  // Float data are not rounded to codes.
  const LoadedImage f = load_image(write_grey(dir.path / "f.tif", OIIO::TypeDesc::FLOAT, 0.5f));
  CHECK(f.rounding.sd_at(0.5) == 0.0);
  // A frame in memory: its depth, grey or colour (Rec. 709 weights, each
  // channel rounded on its own).
  const LoadedImage grey = image_from_frame(cv::Mat(4, 4, CV_8UC1, cv::Scalar(100)), {}, "grey frame");
  CHECK(grey.rounding.sd_at(0.2) == doctest::Approx(srgb8.rounding.sd_at(0.2)).epsilon(1e-6));
  const LoadedImage deep = image_from_frame(cv::Mat(4, 4, CV_16UC1, cv::Scalar(100)), {}, "16-bit frame");
  CHECK(deep.rounding.sd_at(0.2) == doctest::Approx(1.0 / 65535 / sqrt12).epsilon(0.01));
  const LoadedImage colour = image_from_frame(cv::Mat(4, 4, CV_8UC3, cv::Scalar(100, 100, 100)), {}, "colour frame");
  const double weights_sq = 0.2126 * 0.2126 + 0.7152 * 0.7152 + 0.0722 * 0.0722;
  CHECK(colour.rounding.sd_at(0.2) == doctest::Approx(grey.rounding.sd_at(0.2) * std::sqrt(weights_sq)).epsilon(1e-6));
}

TEST_CASE("load_image: signed integers are offset so that the format's minimum is black") {
  TempFolder dir;
  // OpenImageIO hands int16 over as [-1, 1]: -0.5 (-16384) is a quarter of
  // the way up from the format's minimum, +0.5 three quarters.
  for (const float code : {-0.5f, 0.0f, 0.5f}) {
    CAPTURE(code);
    const LoadedImage img = load_image(write_grey(dir.path / "signed16.tif", OIIO::TypeDesc::INT16, code));
    CHECK(img.transfer.curve.name() == "linear");
    CHECK(img.luminance.at<float>(2, 2) == doctest::Approx(0.5 * (code + 1)).epsilon(1e-4));
    CHECK(img.transfer.reason.find("signed, its minimum taken as black") != std::string::npos);
  }
}

TEST_CASE("load_image: a float image with negative light is refused, noise about a subtracted black is not") {
  TempFolder dir;
  // A 64x64 chart of bars: white 1 on black 0, with noise of 2 % of white.
  cv::Mat chart(64, 64, CV_32F);
  cv::RNG rng(5);
  for (int y = 0; y < chart.rows; ++y)
    for (int x = 0; x < chart.cols; ++x) chart.at<float>(y, x) = ((x / 8) % 2 ? 1.0f : 0.0f) + float(rng.gaussian(0.02));
  const auto load_with = [&](double offset, double gain) {
    const fs::path file = dir.path / "float.tif";
    write_image(file, chart * gain + offset);
    return load_image(file);
  };
  CHECK_NOTHROW(load_with(0.0, 1.0));       // noise dips below 0 about black: fine
  CHECK_NOTHROW(load_with(0.0, 1e6));       // any unit of light
  CHECK_NOTHROW(load_with(-0.02, 1.0));     // 2 % of white below: within the margin
  try {
    load_with(-0.5, 1.0);
    FAIL("an offset of half the white was not refused");
  } catch (const UnusableInput& e) {
    CHECK(std::string(e.what()).find("negative light") != std::string::npos);
    CHECK(std::string(e.what()).find("shift it so that black is 0") != std::string::npos);
  }
  try {
    load_with(-0.1, -1.0);
    FAIL("an image of negative values only was not refused");
  } catch (const UnusableInput& e) {
    CHECK(std::string(e.what()).find("holds no light") != std::string::npos);
  }
}

TEST_CASE("load_image: a TIFF or JPEG cut short is refused, not read with its missing rows black") {
  TempFolder dir;
  cv::Mat chart(256, 256, CV_8U);
  for (int y = 0; y < chart.rows; ++y)
    for (int x = 0; x < chart.cols; ++x) chart.at<uchar>(y, x) = static_cast<uchar>((x / 8 + y / 8) % 2 ? 220 : 30);
  for (const char* name : {"chart.tif", "chart.jpg"}) {
    CAPTURE(name);
    const fs::path whole = dir.path / name;
    write_image(whole, chart);
    REQUIRE_NOTHROW(load_image(whole));
    std::ifstream in(whole, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const fs::path cut = dir.path / (std::string("cut_") + name);
    std::ofstream(cut, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size() * 7 / 10));
    try {
      load_image(cut);
      FAIL("a file cut to 70 % was read");
    } catch (const UnusableInput& e) {
      CHECK(std::string(e.what()).find("truncated or corrupt") != std::string::npos);
    }
  }
}

TEST_CASE("load_image: a stack of frames says so, a thumbnail page does not, a folder is named as one") {
  TempFolder dir;
  CHECK(load_image(write_pages(dir.path / "stack.tif", {8, 8, 8})).more_frames);
  CHECK_FALSE(load_image(write_grey(dir.path / "one.tif", OIIO::TypeDesc::UINT8, 0.5f)).more_frames);
  CHECK_FALSE(load_image(write_pages(dir.path / "thumbnailed.tif", {8, 4})).more_frames);
  fs::create_directories(dir.path / "folder.png");
  try {
    load_image(dir.path / "folder.png");
    FAIL("a folder was read");
  } catch (const std::runtime_error& e) {
    CHECK(std::string(e.what()).find("it is a folder") != std::string::npos);
  }
}

TEST_CASE("load_image: the Orientation tag turns the pixels as shown when asked (chart mode), not otherwise") {
  TempFolder dir;
  // Orientation 6: shown turned 90 degrees clockwise, 2 x 3, the stored
  // left column along the shown top row.
  const fs::path file = write_oriented(dir.path / "turned.tif", 6);
  const LoadedImage stored = load_image(file);
  CHECK(stored.orientation == 6);
  CHECK_FALSE(stored.turned_upright);
  CHECK(stored.luminance.cols == 3);
  LoadOptions upright;
  upright.upright = true;
  const LoadedImage shown = load_image(file, upright);
  CHECK(shown.turned_upright);
  REQUIRE(shown.luminance.cols == 2);
  REQUIRE(shown.luminance.rows == 3);
  CHECK(shown.width == 2);
  CHECK(shown.luminance.at<float>(0, 0) == 11);  // stored (0, 1)
  CHECK(shown.luminance.at<float>(0, 1) == 1);   // stored (0, 0)
  CHECK(shown.luminance.at<float>(2, 0) == 13);  // stored (2, 1)
}

TEST_CASE("load_image: every Orientation turns as the EXIF standard says, reserved values read as stored") {
  TempFolder dir;
  // Where shown pixel (x, y) of write_oriented's image comes from, by the
  // standard's "row 0 / column 0" table (as ImageMagick's -auto-orient
  // shows them; OpenImageIO 2.4's reorient swaps 5 and 7).
  constexpr int W = kOrientedW, H = kOrientedH;
  const float* pixels = kOrientedPixels;
  const auto stored_at = [&](int orientation, int x, int y) {
    switch (orientation) {
      case 2: return pixels[y * W + (W - 1 - x)];
      case 3: return pixels[(H - 1 - y) * W + (W - 1 - x)];
      case 4: return pixels[(H - 1 - y) * W + x];
      case 5: return pixels[x * W + y];
      case 6: return pixels[(H - 1 - x) * W + y];
      case 7: return pixels[(H - 1 - x) * W + (W - 1 - y)];
      case 8: return pixels[x * W + (W - 1 - y)];
      default: return pixels[y * W + x];
    }
  };
  for (int orientation : {1, 2, 3, 4, 5, 6, 7, 8, 9, 0}) {
    CAPTURE(orientation);
    const fs::path file = write_oriented(dir.path / ("o" + std::to_string(orientation) + ".tif"), orientation);
    LoadOptions upright;
    upright.upright = true;
    const LoadedImage shown = load_image(file, upright);
    const bool reserved = orientation < 1 || orientation > 8;
    const bool turned = orientation >= 5 && orientation <= 8;
    CHECK(shown.orientation == (reserved ? 1 : orientation));
    CHECK(shown.turned_upright == (orientation >= 2 && orientation <= 8));
    REQUIRE(shown.luminance.cols == (turned ? H : W));
    REQUIRE(shown.luminance.rows == (turned ? W : H));
    for (int y = 0; y < shown.luminance.rows; ++y)
      for (int x = 0; x < shown.luminance.cols; ++x)
        CHECK(shown.luminance.at<float>(y, x) == stored_at(reserved ? 1 : orientation, x, y));
  }
}
