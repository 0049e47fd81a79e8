#pragma once
// Reading measurement JSONs ("tactres.measurement/2", and /1 from before the
// detectability limit, written by `tactres measure`) back for reports. Only what reports show is read, and each of
// those fields is checked strictly (type, range, consistency); errors name
// the file and the field.
//
// Fields that reports do not use are ignored rather than refused: measure
// owns the schema and may add fields within a version, and a report must
// not break when it does. The schema string itself must match.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "tactres/targets/layout.h"

namespace tactres {

// One orientation's limit as measure decided it (criterion.h, Limit).
struct LimitRecord {
  bool resolved_any = false;
  int group = 0, element = 0;   // discrete limit, valid if resolved_any
  double lp_per_mm = 0.0;       // discrete limit, valid if resolved_any
  std::optional<double> interpolated_lp_per_mm;
  std::optional<double> uncertainty_lp_per_mm;  // 1-sigma of the interpolated limit
  bool beyond_finest = false;   // every element resolved: lp_per_mm is a lower bound
};

// One orientation's two limits (profiles/detectability.h); `reported` in
// MeasurementRecord is the coarser. A /1 file has only the optical limit:
// then `detectability_known` is false and `optical` equals the reported one.
struct LimitParts {
  LimitRecord optical, detectability;
  bool detectability_known = false;
  bool light_limited = false;          // "limited_by": "light/noise"
  std::optional<double> light_needed;  // exposure factor for detectability to reach the optical limit
};

// One element's contrast estimate (m is present only when status is "ok").
struct ElementRecord {
  int group = 0, element = 1;
  BarOrientation orientation = BarOrientation::horizontal_bars;
  double lp_per_mm = 0.0;
  std::string status;             // ok, low_signal, clipped, ... (measure.h, ElementStatus)
  std::optional<double> m, m_sigma;
  bool resolved = false;
  std::optional<double> cnr, cnr_sigma;  // Rose CNR (/2 files, status ok)
  bool detectable = false;
};

struct MeasurementRecord {
  std::filesystem::path path;     // the JSON file it was read from
  std::string design;             // label, e.g. "T1C1"
  std::string layout;             // the layout file measure was given
  std::string layout_sha1;        // of that file's bytes, when measure recorded it
  std::string image;              // the capture
  std::string tactres_version;
  std::string preset;             // empty when absent
  bool usable = false;
  std::string problem;            // why not usable (non-empty when !usable)
  // False for a file that could not be read as a measurement at all (not
  // JSON, truncated, another schema): only path, design (the file's stem)
  // and problem are set, and it takes no part in the layout and criterion
  // checks.
  bool readable = true;
  double threshold = 0.0;         // criterion: m(f) at the limit
  double significance_z = 0.0;    // criterion: m - z * m_sigma > 0
  // Camera sampling limit at the target plane; 0 when measure could not
  // compute it (e.g. no target found).
  double nyquist_h_lp_per_mm = 0.0, nyquist_v_lp_per_mm = 0.0;
  LimitRecord horizontal, vertical;       // the reported limits
  LimitParts horizontal_parts, vertical_parts;
  double detectability_k = 0.0;           // 0 in a /1 file
  std::vector<ElementRecord> elements;

  // measure --out-dir writes <stem>.overlay.png beside <stem>.json.
  std::filesystem::path overlay_path() const;
};

// Validates and converts; `where` (usually the path) prefixes every message.
// Throws std::invalid_argument.
MeasurementRecord measurement_from_json(const nlohmann::json& j, const std::string& where);

// Reads, parses and validates one file. std::runtime_error if it cannot be
// read, std::invalid_argument if it is not a valid measurement; both name
// the path.
MeasurementRecord read_measurement_file(const std::filesystem::path& path);

}  // namespace tactres
