#pragma once
// Measurement outputs: JSON ("tactres.measurement/2"), CSV (one row per
// element and orientation), an overlay PNG, and JUnit XML for CI. All are
// written atomically. Absent values are JSON null / empty CSV cells, never
// NaN or inf.

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>
#include <opencv2/core/mat.hpp>

#include "tactres/camera/image_io.h"
#include "tactres/locate/chart_detect.h"
#include "tactres/measure/measurement.h"

namespace tactres {

// /2 added the detectability limit: each limits.<orientation> block is the
// reported limit (same fields as /1) plus "limited_by", "optical" and
// "detectability"; elements gained signal, noise_sd, pixels_per_bar, cnr,
// cnr_sigma and detectable. /1 files still read (reports/).
inline constexpr const char* kMeasurementSchema = "tactres.measurement/2";
inline constexpr const char* kMeasurementSchemaV1 = "tactres.measurement/1";

struct MeasurementContext {
  std::string image;            // the capture's path as given
  std::string design;           // label, e.g. "T1C1"
  std::string layout;           // the layout file
  std::string layout_sha1;      // of the layout file's bytes; empty in chart mode
  std::string tactres_version;
  const LoadedImage* loaded = nullptr;
  const MeasureOptions* options = nullptr;
  double decode_seconds = 0;
  const ChartDetection* chart = nullptr;  // chart mode: written as the "chart" block
};

nlohmann::json measurement_to_json(const Measurement& m, const MeasurementContext& ctx);

// The "chart" block of the measurement JSON: mode, anchor, polarity, counts.
nlohmann::json chart_to_json(const ChartDetection& d);

// CSV columns (stable, documented in docs/FORMATS.md):
// image,design,group,element,orientation,lp_per_mm,px_per_bar,m,m_sigma,status,resolved,cnr,cnr_sigma,
// detectable,indices
std::string measurement_csv_header();
std::string measurement_csv_rows(const Measurement& m, const MeasurementContext& ctx);

}  // namespace tactres
