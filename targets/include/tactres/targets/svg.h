#pragma once
// The target as SVG in true millimetres, for printing or laser cutting.

#include <filesystem>
#include <string>

#include "tactres/targets/layout.h"

namespace tactres {

// width/height in mm and a viewBox in mm, a background rect for the ground,
// then one rect/circle/polygon per artwork shape in drawing order, coloured
// by the layout's polarity.
std::string target_svg(const TargetLayout& layout);

// Writes target_svg() atomically. Throws std::runtime_error naming the path.
void write_target_svg(const std::filesystem::path& path, const TargetLayout& layout);

}  // namespace tactres
