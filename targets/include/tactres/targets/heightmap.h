#pragma once
// The relief as a float height map: each pixel holds the area-averaged
// height of the relief above the ground, in mm, so the map integrates to the
// raised volume exactly.

#include <filesystem>

#include "tactres/targets/layout.h"
#include "tactres/targets/raster.h"

namespace tactres {

// relief_height_mm * coverage, per pixel (see raster.h for the pixel grid).
ImageF height_map_mm(const TargetLayout& layout, const ImageF& coverage);

// Single-channel FLOAT TIFF in mm, written atomically. Throws
// std::runtime_error naming the path.
void write_height_map_tiff(const std::filesystem::path& path, const TargetLayout& layout,
                           const ImageF& coverage, double px_per_mm);

}  // namespace tactres
