#include "tactres/targets/heightmap.h"

namespace tactres {

ImageF height_map_mm(const TargetLayout& layout, const ImageF& coverage) {
  ImageF h = coverage;
  const float relief = float(layout.relief_height_mm);
  for (float& v : h.pixels) v *= relief;
  return h;
}

void write_height_map_tiff(const std::filesystem::path& path, const TargetLayout& layout,
                           const ImageF& coverage, double px_per_mm) {
  write_gray_image(path, height_map_mm(layout, coverage), PixelFormat::float32, px_per_mm);
}

}  // namespace tactres
