#include "tactres/util/json_fields.h"

#include <cmath>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace tactres {

std::string json_text(const nlohmann::json& j, int indent) {
  return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::string valid_utf8(const std::string& s) {
  // nlohmann's replacing dump validates UTF-8 as it writes the string out;
  // parsing that back gives the repaired bytes.
  return nlohmann::json::parse(json_text(nlohmann::json(s), -1)).get<std::string>();
}

JsonFields::JsonFields(const nlohmann::json& object, std::string where)
    : object_(object), where_(std::move(where)) {
  if (!object_.is_object()) throw std::invalid_argument(where_ + " must be a JSON object");
}

bool JsonFields::has(const char* key) const { return object_.contains(key); }

const nlohmann::json& JsonFields::raw(const char* key) {
  read_.insert(key);
  auto it = object_.find(key);
  if (it == object_.end())
    throw std::invalid_argument(fmt::format("{} lacks the required field \"{}\"", where_, key));
  return *it;
}

const nlohmann::json* JsonFields::raw_optional(const char* key) {
  read_.insert(key);
  auto it = object_.find(key);
  return it == object_.end() ? nullptr : &*it;
}

double JsonFields::number(const char* key, std::optional<double> fallback, double lo, double hi,
                          const char* unit) {
  const nlohmann::json* v = raw_optional(key);
  if (!v) {
    if (fallback) return *fallback;
    throw std::invalid_argument(fmt::format("{} lacks the required field \"{}\" (a number in [{}, {}]{}{})",
                                            where_, key, lo, hi, *unit ? " " : "", unit));
  }
  if (!v->is_number())
    throw std::invalid_argument(fmt::format("{}.{} must be a number", where_, key));
  const double x = v->get<double>();
  if (!std::isfinite(x) || x < lo || x > hi)
    throw std::invalid_argument(fmt::format("{}.{} = {} is out of range: valid is [{}, {}]{}{}",
                                            where_, key, x, lo, hi, *unit ? " " : "", unit));
  return x;
}

int JsonFields::integer(const char* key, std::optional<int> fallback, int lo, int hi) {
  const nlohmann::json* v = raw_optional(key);
  if (!v) {
    if (fallback) return *fallback;
    throw std::invalid_argument(fmt::format("{} lacks the required field \"{}\" (an integer in [{}, {}])",
                                            where_, key, lo, hi));
  }
  if (!v->is_number_integer())
    throw std::invalid_argument(fmt::format("{}.{} must be an integer", where_, key));
  const long long x = v->get<long long>();
  if (x < lo || x > hi)
    throw std::invalid_argument(
        fmt::format("{}.{} = {} is out of range: valid is [{}, {}]", where_, key, x, lo, hi));
  return static_cast<int>(x);
}

bool JsonFields::boolean(const char* key, std::optional<bool> fallback) {
  const nlohmann::json* v = raw_optional(key);
  if (!v) {
    if (fallback) return *fallback;
    throw std::invalid_argument(fmt::format("{} lacks the required field \"{}\" (true or false)", where_, key));
  }
  if (!v->is_boolean())
    throw std::invalid_argument(fmt::format("{}.{} must be true or false", where_, key));
  return v->get<bool>();
}

std::string JsonFields::text(const char* key, std::optional<std::string> fallback,
                             const std::vector<std::string>& allowed) {
  const nlohmann::json* v = raw_optional(key);
  std::string s;
  if (!v) {
    if (fallback) return *fallback;
    throw std::invalid_argument(fmt::format("{} lacks the required field \"{}\"{}", where_, key,
                                            allowed.empty() ? "" : fmt::format(" (one of {})", fmt::join(allowed, ", "))));
  }
  if (!v->is_string()) throw std::invalid_argument(fmt::format("{}.{} must be a string", where_, key));
  s = v->get<std::string>();
  if (!allowed.empty() && std::find(allowed.begin(), allowed.end(), s) == allowed.end())
    throw std::invalid_argument(fmt::format("{}.{} = \"{}\" is not valid: use one of {}", where_,
                                            key, s, fmt::join(allowed, ", ")));
  return s;
}

std::vector<double> JsonFields::numbers(const char* key, size_t count, double lo, double hi,
                                        const char* unit) {
  const nlohmann::json& v = raw(key);
  if (!v.is_array() || v.size() != count)
    throw std::invalid_argument(fmt::format("{}.{} must be an array of {} numbers{}{}", where_, key,
                                            count, *unit ? " in " : "", unit));
  std::vector<double> out;
  for (const auto& e : v) {
    if (!e.is_number() || !std::isfinite(e.get<double>()) || e.get<double>() < lo || e.get<double>() > hi)
      throw std::invalid_argument(fmt::format("{}.{} entries must be numbers in [{}, {}]{}{}", where_,
                                              key, lo, hi, *unit ? " " : "", unit));
    out.push_back(e.get<double>());
  }
  return out;
}

void reject_unknown_fields(const nlohmann::json& object, const std::set<std::string>& valid,
                           const std::string& where) {
  if (!object.is_object()) return;
  std::vector<std::string> unknown;
  for (auto it = object.begin(); it != object.end(); ++it)
    if (!valid.count(it.key())) unknown.push_back(it.key());
  if (unknown.empty()) return;
  throw std::invalid_argument(fmt::format("{} has unknown field(s) {}: valid fields are {}", where,
                                          fmt::join(unknown, ", "), fmt::join(valid, ", ")));
}

void JsonFields::finish() const { reject_unknown_fields(object_, read_, where_); }

}  // namespace tactres
