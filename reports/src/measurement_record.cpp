#include "tactres/reports/measurement_record.h"

#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "tactres/measure/measurement_io.h"
#include "tactres/util/atomic_file.h"
#include "tactres/util/json_fields.h"
#include "tactres/targets/layout_json.h"

namespace tactres {
namespace {

// measure writes absent values as JSON null, never NaN: a nullable field
// must be present, and is either null or a valid number.
std::optional<double> nullable_number(JsonFields& f, const char* key, double lo, double hi, const char* unit = "") {
  const nlohmann::json* v = f.raw_optional(key);
  if (!v) throw std::invalid_argument(fmt::format("{} lacks the required field \"{}\" (a number or null)", f.where(), key));
  if (v->is_null()) return std::nullopt;
  return f.number(key, std::nullopt, lo, hi, unit);  // the standard checks and messages
}

std::optional<int> nullable_integer(JsonFields& f, const char* key, int lo, int hi) {
  const nlohmann::json* v = f.raw_optional(key);
  if (!v) throw std::invalid_argument(fmt::format("{} lacks the required field \"{}\" (an integer or null)", f.where(), key));
  if (v->is_null()) return std::nullopt;
  return f.integer(key, std::nullopt, lo, hi);
}

constexpr double kMaxLpPerMm = 1e4;  // far above any printable target; catches garbage

LimitRecord limit_from_json(const nlohmann::json& j, const std::string& where) {
  JsonFields f(j, where);
  LimitRecord l;
  l.resolved_any = f.boolean("resolved_any", std::nullopt);
  const std::optional<int> group = nullable_integer(f, "group", -10, 20);
  const std::optional<int> element = nullable_integer(f, "element", 1, 6);
  const std::optional<double> lp = nullable_number(f, "lp_per_mm", 1e-6, kMaxLpPerMm, "lp/mm");
  l.interpolated_lp_per_mm = nullable_number(f, "interpolated_lp_per_mm", 1e-6, kMaxLpPerMm, "lp/mm");
  l.uncertainty_lp_per_mm = nullable_number(f, "uncertainty_lp_per_mm", 0, kMaxLpPerMm, "lp/mm");
  l.beyond_finest = f.boolean("beyond_finest", std::nullopt);
  if (l.resolved_any) {
    if (!group || !element || !lp)
      throw std::invalid_argument(
          where + " says resolved_any = true but its group, element or lp_per_mm is null: the file is inconsistent");
    l.group = *group;
    l.element = *element;
    l.lp_per_mm = *lp;
  } else if (group || element || lp || l.interpolated_lp_per_mm || l.beyond_finest) {
    throw std::invalid_argument(where +
                                " says resolved_any = false but gives a limit: the file is inconsistent");
  }
  if (l.uncertainty_lp_per_mm && !l.interpolated_lp_per_mm)
    throw std::invalid_argument(where + " gives uncertainty_lp_per_mm without interpolated_lp_per_mm");
  return l;
}

ElementRecord element_from_json(const nlohmann::json& j, const std::string& where) {
  JsonFields f(j, where);
  ElementRecord e;
  e.group = f.integer("group", std::nullopt, -10, 20);
  e.element = f.integer("element", std::nullopt, 1, 6);
  e.orientation = bar_orientation_from_string(f.text("orientation", std::nullopt, {"horizontal_bars", "vertical_bars"}));
  e.lp_per_mm = f.number("lp_per_mm", std::nullopt, 1e-6, kMaxLpPerMm, "lp/mm");
  e.status = f.text("status", std::nullopt);
  if (e.status.empty()) throw std::invalid_argument(where + ".status is empty");
  // m is a fitted modulation: a little outside [0, 1] is possible noise,
  // anything far outside is not a measurement.
  e.m = nullable_number(f, "m", -10, 10);
  e.m_sigma = nullable_number(f, "m_sigma", 0, 10);
  e.resolved = f.boolean("resolved", std::nullopt);
  if (f.has("cnr")) {  // /2
    e.cnr = nullable_number(f, "cnr", 0, 1e12);
    e.cnr_sigma = nullable_number(f, "cnr_sigma", 0, 1e12);
    e.detectable = f.boolean("detectable", std::nullopt);
  }
  if (e.status == "ok" && (!e.m || !e.m_sigma))
    throw std::invalid_argument(where + " has status \"ok\" but m or m_sigma is null");
  return e;
}

// limits.<orientation> of a /2 file: the reported limit's fields, then its
// two parts; a /1 file has the reported (= optical) fields only.
LimitParts parts_from_json(const nlohmann::json& j, const LimitRecord& reported, const std::string& where) {
  LimitParts p;
  p.optical = reported;
  if (!j.is_object() || !j.contains("optical")) return p;
  JsonFields f(j, where);
  p.optical = limit_from_json(f.raw("optical"), where + ".optical");
  p.detectability = limit_from_json(f.raw("detectability"), where + ".detectability");
  p.detectability_known = true;
  p.light_limited = f.text("limited_by", std::nullopt, {"optics", "light/noise"}) == "light/noise";
  p.light_needed = nullable_number(f, "light_needed_factor", 0, 1e12);
  return p;
}

}  // namespace

std::filesystem::path MeasurementRecord::overlay_path() const {
  return path.parent_path() / (path.stem().string() + ".overlay.png");
}

MeasurementRecord measurement_from_json(const nlohmann::json& j, const std::string& where) {
  JsonFields f(j, where);
  MeasurementRecord r;
  r.path = where;
  const std::string schema = f.text("schema", std::nullopt);
  if (schema != kMeasurementSchema && schema != kMeasurementSchemaV1)
    throw std::invalid_argument(fmt::format(
        "{} is not a tactres measurement (schema \"{}\", expected \"{}\" or \"{}\"): give the JSONs that `tactres "
        "measure` wrote",
        where, schema, kMeasurementSchema, kMeasurementSchemaV1));
  r.design = f.text("design", std::nullopt);
  if (r.design.empty()) throw std::invalid_argument(where + ".design is empty: every measurement needs a design label");
  r.layout = f.text("layout", std::nullopt);
  if (f.has("layout_sha1")) r.layout_sha1 = f.text("layout_sha1", std::nullopt);
  r.image = f.text("image", std::string());
  r.tactres_version = f.text("tactres_version", std::string());
  if (f.has("preset")) r.preset = f.text("preset", std::nullopt);
  r.usable = f.boolean("usable", std::nullopt);
  const nlohmann::json& problem = f.raw("problem");
  if (!problem.is_null() && !problem.is_string()) throw std::invalid_argument(where + ".problem must be a string or null");
  if (problem.is_string()) r.problem = problem.get<std::string>();
  if (!r.usable && r.problem.empty())
    throw std::invalid_argument(where + " says usable = false but gives no problem");

  JsonFields criterion(f.raw("criterion"), where + ".criterion");
  r.threshold = criterion.number("threshold", std::nullopt, 1e-9, 1 - 1e-9);
  r.significance_z = criterion.number("significance_z", std::nullopt, 0, 100);
  if (criterion.has("detectability_k")) r.detectability_k = criterion.number("detectability_k", std::nullopt, 1, 100);

  JsonFields nyquist(f.raw("nyquist_lp_per_mm"), where + ".nyquist_lp_per_mm");
  r.nyquist_h_lp_per_mm = nullable_number(nyquist, "horizontal_bars", 0, kMaxLpPerMm, "lp/mm").value_or(0.0);
  r.nyquist_v_lp_per_mm = nullable_number(nyquist, "vertical_bars", 0, kMaxLpPerMm, "lp/mm").value_or(0.0);

  JsonFields limits(f.raw("limits"), where + ".limits");
  r.horizontal = limit_from_json(limits.raw("horizontal_bars"), where + ".limits.horizontal_bars");
  r.vertical = limit_from_json(limits.raw("vertical_bars"), where + ".limits.vertical_bars");
  r.horizontal_parts = parts_from_json(limits.raw("horizontal_bars"), r.horizontal, where + ".limits.horizontal_bars");
  r.vertical_parts = parts_from_json(limits.raw("vertical_bars"), r.vertical, where + ".limits.vertical_bars");
  if (!r.usable && (r.horizontal.resolved_any || r.vertical.resolved_any))
    throw std::invalid_argument(where + " says usable = false but gives limits: the file is inconsistent");

  const nlohmann::json& elements = f.raw("elements");
  if (!elements.is_array()) throw std::invalid_argument(where + ".elements must be an array");
  for (size_t i = 0; i < elements.size(); ++i)
    r.elements.push_back(element_from_json(elements[i], fmt::format("{}.elements[{}]", where, i)));
  return r;
}

MeasurementRecord read_measurement_file(const std::filesystem::path& path) {
  const std::string text = read_file(path);
  const nlohmann::json j = parse_json_text(text, path.string());
  MeasurementRecord r = measurement_from_json(j, path.string());
  r.path = path;
  return r;
}

}  // namespace tactres
