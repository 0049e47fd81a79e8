#include "tactres/targets/raster.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>

#include <OpenImageIO/imageio.h>
#include <fmt/format.h>

#include "tactres/util/atomic_file.h"
#include "tactres/targets/coverage.h"

namespace tactres {

int raster_size_px(double size_mm, double px_per_mm) {
  return std::max(1, int(std::ceil(size_mm * px_per_mm - 1e-9)));
}

void validate_raster_resolution(const TargetLayout& layout, double px_per_mm) {
  if (!std::isfinite(px_per_mm) || px_per_mm <= 0 || px_per_mm > 2000)
    throw std::invalid_argument(
        fmt::format("raster resolution must be in (0, 2000] px/mm, got {}", px_per_mm));
  const double pixels = std::ceil(layout.width_mm * px_per_mm) * std::ceil(layout.height_mm * px_per_mm);
  if (pixels > kMaxRasterPixels)
    throw std::invalid_argument(fmt::format(
        "a {:g} x {:g} mm target at {:g} px/mm is {:.0f} Mpx, above the {:.0f} Mpx limit: use at "
        "most {:.1f} px/mm",
        layout.width_mm, layout.height_mm, px_per_mm, pixels / 1e6, kMaxRasterPixels / 1e6,
        std::floor(10 * std::sqrt(kMaxRasterPixels / (layout.width_mm * layout.height_mm))) / 10));
}

ImageF coverage_raster(const TargetLayout& layout, double px_per_mm) {
  validate_raster_resolution(layout, px_per_mm);
  ImageF img(raster_size_px(layout.width_mm, px_per_mm), raster_size_px(layout.height_mm, px_per_mm));
  const double px2 = px_per_mm * px_per_mm;
  // Pixel edges as k / px_per_mm (not k * pitch): exact for rational rates.
  auto edge = [&](int k) { return k / px_per_mm; };
  std::vector<double> ox, oy;  // per-column / per-row overlaps of a rect

  // Shapes, not pixels, drive the loop: each visits only its own pixel box.
  for (const ArtworkShape& s : layout.artwork) {
    const RectMm b = s.bounds_mm();
    const int i0 = std::max(0, int(std::floor(b.x0 * px_per_mm)));
    const int j0 = std::max(0, int(std::floor(b.y0 * px_per_mm)));
    const int i1 = std::min(img.width - 1, int(std::ceil(b.x1 * px_per_mm)) - 1);
    const int j1 = std::min(img.height - 1, int(std::ceil(b.y1 * px_per_mm)) - 1);
    if (i1 < i0 || j1 < j0) continue;

    if (s.kind == ArtworkShape::Kind::rect) {
      // A rectangle's pixel overlap is separable: width in x times height in y.
      ox.resize(size_t(i1 - i0 + 1));
      oy.resize(size_t(j1 - j0 + 1));
      for (int i = i0; i <= i1; ++i)
        ox[size_t(i - i0)] = std::max(0.0, std::min(b.x1, edge(i + 1)) - std::max(b.x0, edge(i)));
      for (int j = j0; j <= j1; ++j)
        oy[size_t(j - j0)] = std::max(0.0, std::min(b.y1, edge(j + 1)) - std::max(b.y0, edge(j)));
      for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i)
          img.at(i, j) += float(ox[size_t(i - i0)] * oy[size_t(j - j0)] * px2);
    } else {
      for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i)
          img.at(i, j) +=
              float(intersection_area_mm2(s, RectMm{edge(i), edge(j), edge(i + 1), edge(j + 1)}) * px2);
    }
  }
  // Shapes only touch, never overlap; the clamp absorbs rounding where two meet.
  for (float& v : img.pixels) v = std::clamp(v, 0.0f, 1.0f);
  return img;
}

ImageF printed_levels(const ImageF& coverage, Polarity polarity) {
  ImageF out = coverage;
  if (polarity == Polarity::dark_bars_on_light)
    for (float& v : out.pixels) v = 1.0f - v;
  return out;
}

namespace {

template <class T>
std::vector<T> quantize(const ImageF& image) {
  constexpr double kMax = double(std::numeric_limits<T>::max());
  std::vector<T> q(image.pixels.size());
  for (size_t k = 0; k < q.size(); ++k)
    q[k] = T(std::lround(std::clamp(double(image.pixels[k]), 0.0, 1.0) * kMax));
  return q;
}

}  // namespace

void write_gray_image(const std::filesystem::path& path, const ImageF& image, PixelFormat format,
                      double px_per_mm) {
  if (image.width <= 0 || image.height <= 0 ||
      image.pixels.size() != size_t(image.width) * size_t(image.height))
    throw std::invalid_argument("cannot write " + path.string() + ": empty or inconsistent image");
  AtomicOutput out(path);
  const std::string temp = out.temp_path().string();
  auto writer = OIIO::ImageOutput::create(temp);
  if (!writer)
    throw std::runtime_error("cannot write " + path.string() + ": " + OIIO::geterror());

  const OIIO::TypeDesc type = format == PixelFormat::uint8    ? OIIO::TypeDesc::UINT8
                              : format == PixelFormat::uint16 ? OIIO::TypeDesc::UINT16
                                                              : OIIO::TypeDesc::FLOAT;
  OIIO::ImageSpec spec(image.width, image.height, 1, type);
  spec.attribute("XResolution", float(px_per_mm * 10));
  spec.attribute("YResolution", float(px_per_mm * 10));
  spec.attribute("ResolutionUnit", "cm");
  spec.attribute("Software", "tactres");
  // Area coverage is linear: tagged so (a PNG's gAMA 1.0), or a reader,
  // tactres's own among them, takes an untagged 8-bit file for sRGB.
  spec.attribute("oiio:ColorSpace", "Linear");
  if (!writer->open(temp, spec))
    throw std::runtime_error("cannot write " + path.string() + ": " + writer->geterror());

  bool ok = false;
  switch (format) {
    case PixelFormat::uint8: ok = writer->write_image(type, quantize<std::uint8_t>(image).data()); break;
    case PixelFormat::uint16: ok = writer->write_image(type, quantize<std::uint16_t>(image).data()); break;
    case PixelFormat::float32: ok = writer->write_image(type, image.pixels.data()); break;
  }
  ok = ok && writer->close();
  if (!ok) throw std::runtime_error("cannot write " + path.string() + ": " + writer->geterror());
  out.commit();
}

void write_target_png8(const std::filesystem::path& path, const ImageF& coverage, Polarity polarity,
                       double px_per_mm) {
  write_gray_image(path, printed_levels(coverage, polarity), PixelFormat::uint8, px_per_mm);
}

void write_target_tiff16(const std::filesystem::path& path, const ImageF& coverage,
                         Polarity polarity, double px_per_mm) {
  write_gray_image(path, printed_levels(coverage, polarity), PixelFormat::uint16, px_per_mm);
}

}  // namespace tactres
