#include "tactres/reports/comparison.h"

#include "tactres/util/order_stats.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>
#include <tuple>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "tactres/measure/measurement_io.h"
#include "tactres/targets/layout_json.h"
#include "tactres/util/atomic_file.h"

namespace tactres {
namespace {

namespace fs = std::filesystem;

// The layout field is the path measure was given, as given. When measure
// recorded a digest of the file's bytes in both, the digests decide (one
// file given by two paths is the same layout; a file regenerated at one
// path is not). Otherwise two spellings of one file (relative vs absolute,
// another working directory) are the same layout when both can be read
// here and are byte-identical.
bool same_layout(const MeasurementRecord& x, const MeasurementRecord& y) {
  // The digest first: a layout regenerated at the same path is another one.
  if (!x.layout_sha1.empty() && !y.layout_sha1.empty()) return x.layout_sha1 == y.layout_sha1;
  const std::string &a = x.layout, &b = y.layout;
  if (a == b) return true;
  std::error_code ec;
  if (!fs::is_regular_file(a, ec) || !fs::is_regular_file(b, ec)) return false;
  try {
    return read_file(a) == read_file(b);
  } catch (const std::runtime_error&) {
    return false;
  }
}

// What identifies the target beyond its file name: the element series
// (orientation, group, element, frequency). measure lists every layout
// element, whatever its status; a failed capture lists none.
using Series = std::vector<std::tuple<int, int, int, long long>>;
Series element_series(const MeasurementRecord& r) {
  Series s;
  for (const ElementRecord& e : r.elements)
    s.emplace_back(int(e.orientation), e.group, e.element, std::llround(e.lp_per_mm * 1e6));
  std::sort(s.begin(), s.end());
  return s;
}

// `all` is the reference followed by the designs' measurements. The designs
// are checked among themselves first so that the message says which kind of
// mix it is.
void check_same_target(const std::vector<const MeasurementRecord*>& all) {
  const MeasurementRecord& ref = *all[0];
  const MeasurementRecord& first_design = *all[1];
  for (size_t i = 2; i < all.size(); ++i)
    if (!same_layout(first_design, *all[i]))
      throw std::invalid_argument(fmt::format(
          "mixed layouts: {} was measured on layout \"{}\" but {} on \"{}\"; a comparison needs every design "
          "measured on one target layout",
          first_design.path.string(), first_design.layout, all[i]->path.string(), all[i]->layout));
  if (!same_layout(ref, first_design))
    throw std::invalid_argument(fmt::format(
        "the reference {} was measured on layout \"{}\" but the designs on \"{}\": measure the bare camera on "
        "the same target layout",
        ref.path.string(), ref.layout, first_design.layout));
  const MeasurementRecord* first = nullptr;
  Series first_series;
  for (const MeasurementRecord* r : all) {
    if (r->elements.empty()) continue;
    Series s = element_series(*r);
    if (!first) {
      first = r;
      first_series = std::move(s);
    } else if (s != first_series) {
      throw std::invalid_argument(fmt::format(
          "mixed layouts: {} and {} name the layout \"{}\" but list different elements (groups, elements or "
          "lp/mm differ): the layout file changed between the measurements; re-measure against one layout",
          first->path.string(), r->path.string(), r->layout));
    }
  }
}

void check_same_criterion(const std::vector<const MeasurementRecord*>& all) {
  auto same = [](const MeasurementRecord* a, const MeasurementRecord* b) {
    return a->threshold == b->threshold && a->significance_z == b->significance_z;
  };
  const MeasurementRecord* ref = all[0];
  const MeasurementRecord* first_design = all[1];
  for (size_t i = 2; i < all.size(); ++i)
    if (!same(first_design, all[i]))
      throw std::invalid_argument(fmt::format(
          "mixed criteria: {} used threshold {} (z {}) but {} threshold {} (z {}); limits from different "
          "criteria are not comparable: re-measure with one --threshold",
          first_design->path.string(), first_design->threshold, first_design->significance_z,
          all[i]->path.string(), all[i]->threshold, all[i]->significance_z));
  if (!same(ref, first_design))
    throw std::invalid_argument(fmt::format(
        "mixed criteria: the reference {} used threshold {} (z {}) but the designs threshold {} (z {}); limits "
        "from different criteria are not comparable: re-measure with one --threshold",
        ref->path.string(), ref->threshold, ref->significance_z, first_design->threshold,
        first_design->significance_z));
}

// The detectability limits must share one Rose k to be compared. A /1 file
// (k 0) has no detectability limit and so no k to disagree with.
double common_detectability_k(const std::vector<const MeasurementRecord*>& all) {
  const MeasurementRecord* first = nullptr;
  for (const MeasurementRecord* r : all) {
    if (!(r->detectability_k > 0)) continue;
    if (!first) first = r;
    else if (r->detectability_k != first->detectability_k)
      throw std::invalid_argument(fmt::format(
          "mixed criteria: {} used detectability k {} but {} k {}; detectability limits from different Rose "
          "thresholds are not comparable: re-measure with one --detectability-k",
          first->path.string(), first->detectability_k, r->path.string(), r->detectability_k));
  }
  return first ? first->detectability_k : 0.0;
}

OrientationSummary summarise(const std::vector<const LimitRecord*>& limits) {
  OrientationSummary o;
  if (limits.empty()) return o;
  // Discrete: the coarsest press.
  o.resolved_any = std::all_of(limits.begin(), limits.end(), [](const LimitRecord* l) { return l->resolved_any; });
  if (o.resolved_any) {
    const LimitRecord* coarsest = *std::min_element(
        limits.begin(), limits.end(), [](const LimitRecord* a, const LimitRecord* b) { return a->lp_per_mm < b->lp_per_mm; });
    o.group = coarsest->group;
    o.element = coarsest->element;
    o.lp_per_mm = coarsest->lp_per_mm;
    o.beyond_finest = std::all_of(limits.begin(), limits.end(), [](const LimitRecord* l) { return l->beyond_finest; });
  }
  // Interpolated: only when every press has one, so that the mean is over
  // like quantities.
  std::vector<double> values, sigmas;
  for (const LimitRecord* l : limits) {
    if (!l->interpolated_lp_per_mm) return o;
    values.push_back(*l->interpolated_lp_per_mm);
    if (l->uncertainty_lp_per_mm) sigmas.push_back(*l->uncertainty_lp_per_mm);
  }
  o.interp_lp_per_mm = mean(values);
  if (values.size() == 1) {
    if (!sigmas.empty()) o.interp_sigma_lp_per_mm = sigmas[0];
  } else {
    const double sd = sample_sd(values);
    o.interp_sd_lp_per_mm = sd;
    const double mean_sigma = sigmas.empty() ? 0.0 : mean(sigmas);
    o.interp_sigma_lp_per_mm = std::hypot(sd, mean_sigma);
  }
  return o;
}

std::optional<double> percent(std::optional<double> value, std::optional<double> reference) {
  if (!value || !reference || !(*reference > 0)) return std::nullopt;
  return 100.0 * *value / *reference;
}

// The two limits of one orientation over a row's usable presses, with
// percentages of the reference's reported value `ref_value`.
OrientationParts summarise_parts(const std::vector<const LimitParts*>& presses, std::optional<double> ref_value) {
  OrientationParts p;
  if (presses.empty()) return p;
  std::vector<const LimitRecord*> optical, detectability;
  std::vector<double> light;
  for (const LimitParts* press : presses) {
    optical.push_back(&press->optical);  // a /1 press: its reported limit
    if (!press->detectability_known) continue;
    detectability.push_back(&press->detectability);
    p.light_limited_presses += press->light_limited ? 1 : 0;
    // measure gives no factor rather than 0 when no light is enough
    // (detectability.h): a non-positive one is not a figure to show.
    if (press->light_needed && *press->light_needed > 0) light.push_back(*press->light_needed);
  }
  p.optical = summarise(optical);
  p.optical.pct_of_reference = percent(p.optical.value_lp_per_mm(), ref_value);
  if (detectability.size() != presses.size()) return p;  // some press is /1: unknown
  p.detectability = summarise(detectability);
  p.detectability->pct_of_reference = percent(p.detectability->value_lp_per_mm(), ref_value);
  const int n = int(presses.size());
  p.limited_by = p.light_limited_presses == 0   ? LimitedBy::optics
                 : p.light_limited_presses == n ? LimitedBy::light_noise
                                                : LimitedBy::mixed;
  if (light.size() == presses.size()) p.light_needed_factor = *std::max_element(light.begin(), light.end());
  return p;
}

std::optional<double> mean_hv(const DesignRow& r) {
  const auto h = r.horizontal.value_lp_per_mm(), v = r.vertical.value_lp_per_mm();
  if (!h || !v) return std::nullopt;
  return 0.5 * (*h + *v);
}

// 1-sigma of mean_hv: the interpolated limits' uncertainties (a discrete
// limit carries none).
double mean_hv_sigma(const DesignRow& r) {
  return 0.5 * std::hypot(r.horizontal.interp_sigma_lp_per_mm.value_or(0.0),
                          r.vertical.interp_sigma_lp_per_mm.value_or(0.0));
}

// Fills `row`'s limits, parts and percentages from its usable presses
// (non-empty); `ref` is the reference row, or `row` itself when it is the
// reference (its horizontal and vertical are set before they are read).
void aggregate_row(DesignRow& row, const std::vector<const MeasurementRecord*>& usable, const DesignRow& ref) {
  std::vector<const LimitRecord*> h, v;
  std::vector<const LimitParts*> h_parts, v_parts;
  for (const MeasurementRecord* m : usable) {
    h.push_back(&m->horizontal);
    v.push_back(&m->vertical);
    h_parts.push_back(&m->horizontal_parts);
    v_parts.push_back(&m->vertical_parts);
  }
  row.n = int(usable.size());
  row.horizontal = summarise(h);
  row.vertical = summarise(v);
  const std::optional<double> ref_h = ref.horizontal.value_lp_per_mm(), ref_v = ref.vertical.value_lp_per_mm();
  row.horizontal.pct_of_reference = percent(row.horizontal.value_lp_per_mm(), ref_h);
  row.vertical.pct_of_reference = percent(row.vertical.value_lp_per_mm(), ref_v);
  row.horizontal_parts = summarise_parts(h_parts, ref_h);
  row.vertical_parts = summarise_parts(v_parts, ref_v);
  const std::optional<double> light_h = row.horizontal_parts.light_needed_factor,
                              light_v = row.vertical_parts.light_needed_factor;
  if (light_h && light_v) row.light_needed_factor = std::max(*light_h, *light_v);
  row.mean_hv_lp_per_mm = mean_hv(row);
  row.mean_pct_of_reference = percent(row.mean_hv_lp_per_mm, ref.mean_hv_lp_per_mm);
}

void add_reference_notes(Comparison& c) {
  const DesignRow& ref = c.reference_row;
  for (const auto& [name, s] : {std::pair{"horizontal", &ref.horizontal}, std::pair{"vertical", &ref.vertical}}) {
    if (!s->resolved_any)
      c.notes.push_back(fmt::format("The reference resolved no {}-bar element: {} percentages are not available.",
                                    name, name));
    else if (s->beyond_finest)
      c.notes.push_back(fmt::format(
          "The reference resolved every {}-bar element: its {} limit ({:.2f} lp/mm) is a lower bound, so the "
          "{} percentages are upper bounds.",
          name, name, s->lp_per_mm, name));
    else if (!s->interp_lp_per_mm)
      c.notes.push_back(fmt::format("The reference has no interpolated {} limit: {} percentages use its discrete "
                                    "limit ({:.2f} lp/mm).",
                                    name, name, s->lp_per_mm));
  }
  if (!(c.nyquist_h_lp_per_mm > 0) || !(c.nyquist_v_lp_per_mm > 0))
    c.notes.push_back("The reference gives no sampling (Nyquist) limit.");
}

}  // namespace

std::optional<double> OrientationSummary::value_lp_per_mm() const {
  if (interp_lp_per_mm) return interp_lp_per_mm;
  if (resolved_any) return lp_per_mm;
  return std::nullopt;
}

const char* to_string(LimitedBy l) {
  switch (l) {
    case LimitedBy::unknown: return "";
    case LimitedBy::optics: return "optics";
    case LimitedBy::light_noise: return "light/noise";
    case LimitedBy::mixed: return "mixed";
  }
  return "";
}

LightNeededWords light_needed_words(std::optional<double> factor) {
  if (!factor || !(*factor > 0) || !std::isfinite(*factor)) return {"n/a", ""};
  // Two significant digits: the factor comes from a CNR of a few percent
  // uncertainty, and a bright design's spare light spans decades.
  if (*factor >= 1) return {fmt::format("×{:.{}f}", *factor, *factor < 10 ? 1 : 0), "more light"};
  if (*factor < 0.01) return {"<0.01×", "light to spare"};
  return {fmt::format("{:.2g}×", *factor), "light to spare"};
}

std::string light_needed_text(std::optional<double> factor) {
  const LightNeededWords w = light_needed_words(factor);
  if (w.meaning.empty()) return w.factor;
  return w.factor + (*factor >= 1 ? " " : ": ") + w.meaning;
}

const char* to_string(RowStatus s) {
  switch (s) {
    case RowStatus::reference: return "reference";
    case RowStatus::ok: return "ok";
    case RowStatus::partly_failed: return "partly_failed";
    case RowStatus::failed: return "failed";
  }
  return "failed";
}

Comparison compare_designs(std::vector<MeasurementRecord> measurements, MeasurementRecord reference) {
  if (measurements.empty())
    throw std::invalid_argument(
        "no design measurements to compare: give at least one measurement JSON besides --reference");
  if (!reference.usable)
    throw std::invalid_argument(fmt::format(
        "the reference {} is a failed measurement ({}): percentages of the raw CMOS limit need a usable "
        "measurement of the bare camera; fix and re-measure it",
        reference.path.string(), reference.problem));

  std::vector<const MeasurementRecord*> all{&reference};
  for (const MeasurementRecord& m : measurements)
    if (m.readable) all.push_back(&m);
  if (all.size() > 1) {
    check_same_target(all);
    check_same_criterion(all);
  }

  Comparison c;
  c.threshold = reference.threshold;
  c.significance_z = reference.significance_z;
  c.detectability_k = common_detectability_k(all);
  c.layout = reference.layout;
  c.nyquist_h_lp_per_mm = reference.nyquist_h_lp_per_mm;
  c.nyquist_v_lp_per_mm = reference.nyquist_v_lp_per_mm;

  // Reference row: its own limits, 100 % by definition.
  DesignRow& ref = c.reference_row;
  ref.design = reference.design;
  ref.status = RowStatus::reference;
  aggregate_row(ref, {&reference}, ref);
  add_reference_notes(c);

  // Group by design label, in order of first appearance.
  std::map<std::string, size_t> row_of;
  for (size_t i = 0; i < measurements.size(); ++i) {
    const std::string& d = measurements[i].design;
    auto [it, added] = row_of.emplace(d, c.designs.size());
    if (added) {
      c.designs.emplace_back();
      c.designs.back().design = d;
    }
    c.designs[it->second].presses.push_back(i);
  }
  for (DesignRow& row : c.designs) {
    std::vector<const MeasurementRecord*> usable;
    for (size_t i : row.presses) {
      const MeasurementRecord& m = measurements[i];
      if (m.usable) usable.push_back(&m);
      else  // why a file could not be read names it already
        row.problems.push_back(m.readable ? m.path.filename().string() + ": " + m.problem : m.problem);
    }
    row.n_failed = int(row.presses.size() - usable.size());
    row.status = usable.empty() ? RowStatus::failed : row.n_failed > 0 ? RowStatus::partly_failed : RowStatus::ok;
    if (!usable.empty()) aggregate_row(row, usable, ref);
  }

  // Competition ranking by the mean of H and V of the REPORTED limits (the
  // coarser of optics and detectability), best first: a design that light
  // holds back ranks by what it resolves, not by what its optics could. A
  // design is only counted better when it is better beyond 2 combined
  // sigma: two designs that the measurements cannot tell apart share a
  // rank, so a rank never claims more than the error bars do.
  for (DesignRow& row : c.designs) {
    if (!row.mean_hv_lp_per_mm) continue;
    int better = 0;
    for (const DesignRow& other : c.designs)
      if (other.mean_hv_lp_per_mm &&
          *other.mean_hv_lp_per_mm - *row.mean_hv_lp_per_mm >
              2 * std::hypot(mean_hv_sigma(row), mean_hv_sigma(other)))
        ++better;
    row.rank = better + 1;
  }

  c.measurements = std::move(measurements);
  c.reference = std::move(reference);
  return c;
}

namespace {

// One design's file. One that cannot be read (missing, a folder, not
// JSON, truncated, a malformed measurement) is a failed record, not the
// end of the report: it joins its design when the file still names one,
// else it is named after its file. Another tactres file (a layout or a
// truth caught by a glob) is no design's, and is refused as before.
MeasurementRecord read_design_file(const fs::path& f) {
  const auto failed = [&](const std::string& why, const std::string& design) {
    MeasurementRecord r;
    r.path = f;
    r.readable = false;
    r.design = design.empty() ? f.stem().string() : design;
    r.problem = why + (design.empty() ? " (its design is unknown: the row is named after the file)" : "");
    return r;
  };
  nlohmann::json j;
  try {
    j = parse_json_text(read_file(f), f.string());
  } catch (const std::exception& e) {
    return failed(e.what(), "");
  }
  const std::string schema = j.is_object() && j.contains("schema") && j["schema"].is_string() ? j["schema"] : "";
  if (schema.rfind("tactres.", 0) == 0 && schema != kMeasurementSchema && schema != kMeasurementSchemaV1)
    return measurement_from_json(j, f.string());  // throws: not a measurement
  try {
    MeasurementRecord r = measurement_from_json(j, f.string());
    r.path = f;
    return r;
  } catch (const std::exception& e) {
    const bool named = j.is_object() && j.contains("design") && j["design"].is_string();
    return failed(e.what(), named ? j["design"].get<std::string>() : "");
  }
}

}  // namespace

Comparison load_comparison(const std::vector<fs::path>& measurement_files, const fs::path& reference_file) {
  if (reference_file.empty())
    throw std::invalid_argument(
        "no reference: give the bare camera's measurement with --reference CMOS.json (percentages are of its "
        "limit)");
  if (measurement_files.empty())
    throw std::invalid_argument("no measurement JSONs given: list the designs' result JSONs before --reference");

  const fs::path ref_id = canonical_path(reference_file);
  std::vector<fs::path> files;
  std::map<fs::path, fs::path> seen;
  for (const fs::path& f : measurement_files) {
    const fs::path id = canonical_path(f);
    if (id == ref_id) continue;  // e.g. out/*.json includes the reference
    if (auto [it, added] = seen.emplace(id, f); !added)
      throw std::invalid_argument(fmt::format("{} is given twice (also as {}): each measurement counts once",
                                              f.string(), it->second.string()));
    files.push_back(f);
  }
  if (files.empty())
    throw std::invalid_argument(fmt::format(
        "the only measurement given is the reference {}: list the designs' result JSONs too",
        reference_file.string()));

  MeasurementRecord reference = read_measurement_file(reference_file);
  std::vector<MeasurementRecord> records;
  for (const fs::path& f : files) records.push_back(read_design_file(f));
  return compare_designs(std::move(records), std::move(reference));
}

}  // namespace tactres
