#pragma once
// Strict reading of one JSON object: every read names its field in errors,
// checks type and physical range, and finish() rejects unknown keys while
// listing the valid ones. Used by every tactres file reader.

#include <optional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace tactres {

// JSON text for a file: `indent` as nlohmann's dump, and bytes that are not
// UTF-8 (a Latin-1 file name, a design label from a shell) replaced by
// U+FFFD instead of throwing. Every tactres JSON output is written so.
std::string json_text(const nlohmann::json& j, int indent = 2);

// `s` with every byte sequence that is not UTF-8 replaced by U+FFFD.
std::string valid_utf8(const std::string& s);

// Throws std::invalid_argument naming `where`, the unknown field(s) and
// the valid ones when `object` holds a key outside `valid`.
void reject_unknown_fields(const nlohmann::json& object, const std::set<std::string>& valid,
                           const std::string& where);

class JsonFields {
 public:
  // `where` names the object in messages, e.g. "scene.effects[2]".
  JsonFields(const nlohmann::json& object, std::string where);

  bool has(const char* key) const;
  // Numbers: finite, within [lo, hi]; `unit` is appended to messages.
  double number(const char* key, std::optional<double> fallback, double lo, double hi,
                const char* unit = "");
  int integer(const char* key, std::optional<int> fallback, int lo, int hi);
  bool boolean(const char* key, std::optional<bool> fallback);
  std::string text(const char* key, std::optional<std::string> fallback,
                   const std::vector<std::string>& allowed = {});
  std::vector<double> numbers(const char* key, size_t count, double lo, double hi,
                              const char* unit = "");
  // The raw value (must exist); marks the key as read.
  const nlohmann::json& raw(const char* key);
  const nlohmann::json* raw_optional(const char* key);

  // Throws std::invalid_argument for keys that were never read.
  void finish() const;

  const std::string& where() const { return where_; }

 private:
  const nlohmann::json& object_;
  std::string where_;
  std::set<std::string> read_;
};

}  // namespace tactres
