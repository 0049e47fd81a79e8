#pragma once
// Layout JSON ("tactres.target/1"): the exchange format between the
// generator, the simulator and the analyzer. See docs/FORMATS.md.

#include <filesystem>
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "tactres/targets/layout.h"

namespace tactres {

nlohmann::json layout_to_json(const TargetLayout& layout);

// Validates schema, units and every field; throws std::invalid_argument that
// names the offending field.
TargetLayout layout_from_json(const nlohmann::json& j);

// Reads and validates a layout file. Errors name the path: std::runtime_error
// for I/O, std::invalid_argument for malformed content.
TargetLayout read_layout_file(const std::filesystem::path& path);

// Writes the layout JSON atomically.
void write_layout_file(const std::filesystem::path& path, const TargetLayout& layout);

// Parses JSON text; a syntax error becomes std::invalid_argument naming
// `what` (usually a path) and the byte offset.
nlohmann::json parse_json_text(const std::string& text, const std::string& what);

}  // namespace tactres
