#pragma once
// The design comparison behind `tactres report`: measurements grouped by
// design label, set against one reference (the bare camera, "raw CMOS").
//
// Reports compute nothing that measure should have computed. This is only
// aggregation of measure's results: means and spreads over repeated
// presses, percentages of the reference, the mean of H and V, and a rank.
// docs/REPORT.md defines every number; the definitions are repeated at the
// fields below.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "tactres/reports/measurement_record.h"

namespace tactres {

// One orientation (horizontal or vertical bars) of one design row.
struct OrientationSummary {
  // Discrete limit: the coarsest of the usable presses' discrete limits, so
  // that every press resolved it and every coarser element. Absent
  // (resolved_any false) when some press resolved nothing.
  bool resolved_any = false;
  int group = 0, element = 0;
  double lp_per_mm = 0.0;
  bool beyond_finest = false;  // every press resolved every element: lp_per_mm is a lower bound

  // Interpolated limit: the mean over the usable presses; absent unless
  // every press has one.
  std::optional<double> interp_lp_per_mm;
  // Sample standard deviation of the presses' interpolated limits (n >= 2).
  std::optional<double> interp_sd_lp_per_mm;
  // 1-sigma uncertainty. n = 1: the measurement's own. n >= 2: the spread
  // and the mean of the presses' uncertainties in quadrature,
  // sqrt(sd^2 + mean(sigma_i)^2): the uncertainty of one press of this
  // design, not the standard error of the mean.
  std::optional<double> interp_sigma_lp_per_mm;

  // The value compared: interp_lp_per_mm if present, else the discrete
  // lp_per_mm; absent when nothing was resolved.
  std::optional<double> value_lp_per_mm() const;

  // 100 * value / the reference's value in the same orientation.
  std::optional<double> pct_of_reference;
};

// Which of the two limits (profiles/detectability.h) is the reported one,
// over a row's usable presses.
enum class LimitedBy {
  unknown,      // some press predates the detectability limit (/1): the reported limit is its optical one
  optics,       // every press: the optical limit
  light_noise,  // every press: the detectability limit
  mixed,        // the presses disagree
};
const char* to_string(LimitedBy l);  // "", "optics", "light/noise", "mixed"

// One orientation's two limits, each aggregated over the presses like the
// reported one (OrientationSummary), with percentages of the reference's
// REPORTED limit, so that the three percentages of a row share one scale.
struct OrientationParts {
  OrientationSummary optical;
  // Absent unless every usable press has a detectability limit (/2 files).
  std::optional<OrientationSummary> detectability;
  LimitedBy limited_by = LimitedBy::unknown;
  int light_limited_presses = 0;
  // Exposure factor at which the detectability limit would reach the
  // optical one: the largest over the presses (the light that every press
  // needs), absent unless every usable press gives one.
  std::optional<double> light_needed_factor;
};

enum class RowStatus {
  reference,      // the reference row
  ok,             // every press usable
  partly_failed,  // some presses unusable: the usable ones are aggregated
  failed,         // no usable press: shown with its problem, never ranked
};
const char* to_string(RowStatus s);

struct DesignRow {
  std::string design;
  RowStatus status = RowStatus::ok;
  std::vector<size_t> presses;  // indices into Comparison::measurements, input order
  int n = 0;                    // usable presses aggregated
  int n_failed = 0;             // unusable presses (shown, never dropped)
  std::vector<std::string> problems;  // the unusable presses' problems, "file: problem"
  OrientationSummary horizontal, vertical;  // the reported limits: what is compared and ranked
  OrientationParts horizontal_parts, vertical_parts;
  // The design's "light needed": the larger of the H and V factors, so that
  // both orientations reach their optical limits; absent unless both exist.
  std::optional<double> light_needed_factor;
  // (H value + V value) / 2, when both exist.
  std::optional<double> mean_hv_lp_per_mm;
  // 100 * mean_hv / the reference's mean_hv.
  std::optional<double> mean_pct_of_reference;
  // 1 = best, by mean_hv (of the reported limits) descending; designs
  // whose means differ by no more than 2 combined sigma share a rank
  // (1, 2, 2, 4).
  // Absent for the reference, failed designs, and designs without a mean.
  std::optional<int> rank;
};

struct Comparison {
  // Every design measurement, in input order; the reference is separate.
  std::vector<MeasurementRecord> measurements;
  MeasurementRecord reference;
  DesignRow reference_row;        // status reference, percentages 100
  std::vector<DesignRow> designs;  // in order of first appearance
  // Shared by every input (checked).
  double threshold = 0.0, significance_z = 0.0;
  // The Rose threshold of the detectability limit, shared by every input
  // that has one (checked); 0 when none has (all /1).
  double detectability_k = 0.0;
  std::string layout;
  // The camera's sampling limit at the target plane, from the reference.
  double nyquist_h_lp_per_mm = 0.0, nyquist_v_lp_per_mm = 0.0;
  // Things a reader must know, e.g. a reference limit that is a lower bound.
  std::vector<std::string> notes;
};

// The light-needed factor in words, as the page and the command line say
// it: {"×1.8", "more light"}, {"0.4×", "light to spare"}, or {"n/a", ""}
// when it is absent or not positive.
struct LightNeededWords {
  std::string factor, meaning;
};
LightNeededWords light_needed_words(std::optional<double> factor);
// The same in one line: "×1.8 more light", "0.4×: light to spare", "n/a".
std::string light_needed_text(std::optional<double> factor);

// Groups and aggregates. Throws std::invalid_argument, naming the files,
// for: no design measurement; a failed reference; mixed layouts (the
// "layout" strings, or the elements' frequencies); mixed criteria (threshold
// and z; and the detectability k among the inputs that have one).
Comparison compare_designs(std::vector<MeasurementRecord> measurements, MeasurementRecord reference);

// Reads the files and compares. Refuses (std::invalid_argument) an empty
// list, a missing reference and a file given twice; a results list that
// contains the reference file itself (e.g. a glob) just skips it there.
// Unreadable or malformed files throw, naming the file.
Comparison load_comparison(const std::vector<std::filesystem::path>& measurement_files,
                           const std::filesystem::path& reference_file);

}  // namespace tactres
