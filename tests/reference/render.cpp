// Rendering: for each pixel centre, unproject through the camera, meet the
// target plane, evaluate the analytically blurred pattern there. Then noise,
// quantisation and a plain file with no colour metadata.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <random>
#include <stdexcept>
#include <thread>

#include <OpenImageIO/imageio.h>

#include "reference_renderer.h"

namespace reference {
namespace {

// The image value at target point (x, y) mm.
struct Shader {
  const BlurredPattern& pattern;
  const Scene& scene;
  double ink = 0, ground = 0;     // albedo
  double slope_gain = 0;          // relief: gain_per_slope * relief_mm
  Vec2 light{1, 0};               // relief: unit light direction in the target plane

  double background() const { return scene.mode == "relief" ? scene.level : ground; }
  double operator()(double x_mm, double y_mm) const {
    if (scene.mode == "relief") {
      const Vec2 g = pattern.coverage_gradient_per_mm(x_mm, y_mm);
      return scene.level + slope_gain * (light[0] * g[0] + light[1] * g[1]);
    }
    return ground + (ink - ground) * pattern.coverage(x_mm, y_mm);
  }
};

void render_rows(const Camera& camera, const RigidTransform& T, const Shader& shade, std::atomic<int>& next_row,
                 Image& image) {
  std::vector<Vec3> rays;
  for (int row = next_row++; row < image.height_px; row = next_row++) {
    camera.unproject_row(row, rays);
    for (int x = 0; x < image.width_px; ++x) {
      Vec2 p_mm;
      image.at(x, row) = static_cast<float>(intersect_target_plane(T, rays[x], p_mm) ? shade(p_mm[0], p_mm[1])
                                                                                      : shade.background());
    }
  }
}

std::vector<unsigned char> quantised_bytes(const Image& image, OIIO::TypeDesc type) {
  const size_t n = image.values.size();
  std::vector<unsigned char> bytes(n * type.size());
  if (type == OIIO::TypeDesc::FLOAT) {
    std::memcpy(bytes.data(), image.values.data(), n * sizeof(float));
    return bytes;
  }
  const double top = type == OIIO::TypeDesc::UINT16 ? 65535.0 : 255.0;
  for (size_t i = 0; i < n; ++i) {
    const double v = std::round(std::clamp(static_cast<double>(image.values[i]), 0.0, 1.0) * top);
    if (type == OIIO::TypeDesc::UINT16) {
      const auto u = static_cast<std::uint16_t>(v);
      std::memcpy(bytes.data() + 2 * i, &u, 2);
    } else {
      bytes[i] = static_cast<unsigned char>(v);
    }
  }
  return bytes;
}

}  // namespace

Image render_image(const Layout& layout, const Camera& camera, const Pose& pose, const Scene& scene) {
  if (scene.mode != "albedo" && scene.mode != "relief")
    throw std::invalid_argument("scene: mode '" + scene.mode + "' is not albedo or relief");
  const BlurredPattern pattern(layout.ink_rects_mm, scene.sigma_mm);
  Shader shade{pattern, scene};
  shade.ink = scene.light_bars_on_dark ? scene.ground_albedo : scene.ink_albedo;
  shade.ground = scene.light_bars_on_dark ? scene.ink_albedo : scene.ground_albedo;
  const double relief_mm = scene.relief_mm >= 0 ? scene.relief_mm : layout.relief_height_mm;
  shade.slope_gain = scene.gain_per_slope * relief_mm;
  shade.light = {std::cos(scene.light_azimuth_deg * M_PI / 180), std::sin(scene.light_azimuth_deg * M_PI / 180)};

  const RigidTransform T = camera_from_target(pose, layout.width_mm, layout.height_mm);
  Image image;
  image.width_px = camera.width_px();
  image.height_px = camera.height_px();
  image.values.assign(static_cast<size_t>(image.width_px) * image.height_px, 0.0f);
  std::atomic<int> next_row{0};
  const unsigned threads = std::max(1u, std::thread::hardware_concurrency());
  std::vector<std::thread> pool;
  for (unsigned i = 0; i < threads; ++i)
    pool.emplace_back(render_rows, std::cref(camera), std::cref(T), std::cref(shade), std::ref(next_row),
                      std::ref(image));
  for (auto& t : pool) t.join();
  return image;
}

double level_step(const Layout& layout, const Scene& scene) {
  if (scene.mode == "relief") {
    const double relief_mm = scene.relief_mm >= 0 ? scene.relief_mm : layout.relief_height_mm;
    return scene.gain_per_slope * relief_mm / (std::sqrt(2 * M_PI) * scene.sigma_mm);
  }
  return std::abs(scene.ground_albedo - scene.ink_albedo);
}

double noise_sigma(const Layout& layout, const Scene& scene) {
  if (scene.snr_db <= 0) return 0;
  return level_step(layout, scene) / std::pow(10.0, scene.snr_db / 20.0);
}

void add_gaussian_noise(Image& image, double sigma, std::uint64_t seed) {
  if (sigma <= 0) return;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, sigma);
  for (float& v : image.values) v = static_cast<float>(v + normal(rng));
}

void write_image(const std::string& path, const Image& image, std::string format) {
  if (format.empty()) {
    const bool tiff = path.size() > 4 && (path.ends_with(".tif") || path.ends_with(".tiff"));
    format = tiff ? "tiff32f" : "png16";
  }
  OIIO::TypeDesc type;
  if (format == "png16") type = OIIO::TypeDesc::UINT16;
  else if (format == "png8") type = OIIO::TypeDesc::UINT8;
  else if (format == "tiff32f") type = OIIO::TypeDesc::FLOAT;
  else throw std::invalid_argument("write_image: format '" + format + "' is not png16, png8 or tiff32f");

  // Deliberately nothing colour-related in the spec (no oiio:ColorSpace, no
  // ICCProfile): OIIO's PNG writer then writes no gAMA, sRGB, cHRM or iCCP
  // chunk (checked by image_output_test.cpp).
  const OIIO::ImageSpec spec(image.width_px, image.height_px, 1, type);
  auto out = OIIO::ImageOutput::create(path);
  if (!out) throw std::runtime_error("write_image: " + OIIO::geterror());
  const std::vector<unsigned char> bytes = quantised_bytes(image, type);
  if (!out->open(path, spec) || !out->write_image(type, bytes.data()) || !out->close())
    throw std::runtime_error("write_image: " + out->geterror());
}

}  // namespace reference
