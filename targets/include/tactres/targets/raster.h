#pragma once
// The target as a raster with exact area-coverage anti-aliasing, and the
// single-channel image writers shared by the raster and height-map outputs.
//
// Pixel (col, row) covers [col, col + 1) x [row, row + 1) / px_per_mm in the
// target frame: row 0 is the top edge, pixel centres sit at half-integers.

#include <filesystem>
#include <vector>

#include "tactres/targets/layout.h"

namespace tactres {

// A single-channel float image, row-major.
struct ImageF {
  int width = 0;
  int height = 0;
  std::vector<float> pixels;

  ImageF() = default;
  ImageF(int w, int h, float fill = 0.0f) : width(w), height(h), pixels(size_t(w) * size_t(h), fill) {}
  float& at(int x, int y) { return pixels[size_t(y) * size_t(width) + size_t(x)]; }
  float at(int x, int y) const { return pixels[size_t(y) * size_t(width) + size_t(x)]; }
};

// Largest raster the emitters make, in pixels: a float image of this size is
// 1 GiB, so anything larger is almost surely a mistyped --px-per-mm.
inline constexpr double kMaxRasterPixels = 268435456.0;  // 2^28

// ceil(size_mm * px_per_mm), ignoring a rounding excess of 1e-9 px so that,
// e.g., 20 mm at 40.1 px/mm is 802 px, not 803.
int raster_size_px(double size_mm, double px_per_mm);

// Throws std::invalid_argument unless px_per_mm is finite, in (0, 2000], and
// the raster of `layout` stays within kMaxRasterPixels.
void validate_raster_resolution(const TargetLayout& layout, double px_per_mm);

// Each pixel's inked fraction in [0, 1]: the exact area of the artwork inside
// the pixel square over the pixel's area.
ImageF coverage_raster(const TargetLayout& layout, double px_per_mm);

// Printed grey level of an inked fraction: the ground is 1 and ink 0 for
// dark_bars_on_light, the reverse for light_bars_on_dark.
ImageF printed_levels(const ImageF& coverage, Polarity polarity);

enum class PixelFormat { uint8, uint16, float32 };

// Writes a single-channel image atomically with OpenImageIO (format from the
// extension). Integer formats map [0, 1] to the full code range (rounded,
// clamped); float32 stores the values as they are. The resolution tags say
// px_per_mm so the file prints at true size. Throws std::runtime_error naming
// the path.
void write_gray_image(const std::filesystem::path& path, const ImageF& image, PixelFormat format,
                      double px_per_mm);

// The printed target: 8-bit PNG / 16-bit TIFF of printed_levels(coverage).
void write_target_png8(const std::filesystem::path& path, const ImageF& coverage, Polarity polarity,
                       double px_per_mm);
void write_target_tiff16(const std::filesystem::path& path, const ImageF& coverage,
                         Polarity polarity, double px_per_mm);

}  // namespace tactres
