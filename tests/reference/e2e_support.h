// Support for the end-to-end suite on the reference renderer's captures:
// the cases, running the real `tactres` binary, comparing with the truth.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "reference_renderer.h"

namespace reference::e2e {

namespace fs = std::filesystem;

// A fresh folder under the system temp dir, removed on destruction.
struct TempDir {
  explicit TempDir(const std::string& tag);
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  fs::path path;
};

// The tactres binary under test: the build's, or TACTRES_REFERENCE_TACTRES
// (to try another build by hand).
std::string tactres_binary();
// std::system's exit code (-1 when the command did not exit).
int run_shell(const std::string& cmd);
std::string read_text(const fs::path& p);
// The blur whose limit falls at the geometric middle between an element and
// the next one (a factor 2^(1/12) above the first): there m_true is 0.13 on
// the last resolved element and 0.076 on the next, so neither sits on the
// threshold.
double sigma_for_limit_between(int group, int element);

// `tactres generate --out DIR` with default options, once per process.
const fs::path& default_layout_path();
const Layout& default_layout();

struct CaseSpec {
  std::string name;
  std::string camera = "pinhole720";  // pinhole720 | wide_angle | pinhole5mp
  Pose pose;
  Scene scene;
  std::string extension = ".png";     // .png (16-bit) or .tif (32-bit float)
  bool noise_free() const { return scene.snr_db <= 0; }
};

// The twelve cases of issue 12 (fronto ... 2448x2048 rotated and tilted).
std::vector<CaseSpec> issue_cases();
const CaseSpec& issue_case(const std::string& name);
Camera camera_named(const std::string& name);

// A case rendered once without noise, for seeded noisy repeats: its camera
// model written into `dir`, the clean image, the truth, and the noise sigma
// of the case's own SNR.
struct CleanCase {
  CaseSpec spec;
  fs::path camera_model;
  Image clean;
  Truth truth;
  double noise_sigma = 0;
};
CleanCase render_clean_case(const std::string& name, const fs::path& dir, double snr_db);

// One orientation's measured limit, as in the measurement JSON.
struct MeasuredLimit {
  std::optional<double> interpolated_lp_per_mm;
  std::optional<double> uncertainty_lp_per_mm;
  bool resolved_any = false;
};

struct CaseResult {
  std::string name;
  int exit_code = -1;
  bool usable = false;
  std::string problem;
  std::string transfer;                      // input.transfer as reported
  Truth truth;
  MeasuredLimit horizontal, vertical;
  std::optional<double> rel_error_h, rel_error_v;  // measured / true - 1
  double max_abs_dm = 0;          // over `ok` elements with truth px_per_bar >= 3
  int elements_compared = 0;
  std::vector<std::string> falsely_resolved;  // resolved although m_true < threshold
  std::vector<std::string> notes;             // e.g. elements >= 3 px/bar that are not ok
  double render_seconds = 0, measure_seconds = 0;
  const MeasuredLimit& limit(const std::string& orientation) const {
    return orientation == "horizontal_bars" ? horizontal : vertical;
  }
  std::optional<double> rel_error(const std::string& orientation) const {
    return orientation == "horizontal_bars" ? rel_error_h : rel_error_v;
  }
};

// Renders the case (noise with the scene's seed) into dir and measures it with
// `tactres measure IMAGE --layout L --camera C -o OUT.json` plus extra_args.
CaseResult run_case(const CaseSpec& spec, const fs::path& dir, const std::string& extra_args = "");
// Same, memoised per process by name and extra_args (the default-options
// results are shared by the per-case tests and the median test).
const CaseResult& cached_case_result(const std::string& name, const std::string& extra_args = "");

// Measure an image that is already rendered and compare it with truth.
CaseResult measure_and_compare(const std::string& name, const fs::path& image, const fs::path& camera_model,
                               const Truth& truth, const fs::path& out_json, const std::string& extra_args);

std::string summary_line(const CaseResult& r);

// The extra options of every measure call, from TACTRES_REFERENCE_MEASURE_ARGS
// (e.g. "--transfer linear" for a manual check); empty by default. The binary
// itself is TACTRES_BINARY unless TACTRES_REFERENCE_TACTRES names another.
std::string env_measure_args();

}  // namespace reference::e2e
