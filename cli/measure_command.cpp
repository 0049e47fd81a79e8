// `tactres measure`: lp/mm of one capture or a batch, with CI exit codes.
#include <algorithm>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <mutex>
#include <set>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "command.h"
#include "exit_codes.h"
#include "tactres/util/json_fields.h"
#include "tactres/measure/chart_measure.h"
#include "tactres/camera/image_io.h"
#include "tactres/measure/measure.h"
#include "tactres/measure/measurement_io.h"
#include "tactres/measure/overlay.h"
#include "tactres/util/atomic_file.h"
#include "tactres/util/parallel.h"
#include "tactres/targets/layout_json.h"

namespace tactres::cli {
namespace {

namespace fs = std::filesystem;

struct Args {
  std::vector<std::string> images;
  std::string layout, camera, design, output, csv, overlay, out_dir, junit;
  std::string preset = "balanced", transfer = "auto", non_finite = "mask", signature = "auto";
  double threshold = 0.10;
  double detectability_k = 5.0;
  std::optional<double> require_h, require_v, min_px_per_bar;
  int channel = -1;
  int jobs = 0;
  // Chart mode (--chart usaf1951): a standard chart without layout or fiducials.
  std::string chart;
  std::optional<int> largest_group;
  int largest_element = 1;
  std::optional<double> px_per_mm;
};

// What one image produced, for the summary, the exit code and JUnit.
struct Outcome {
  std::string image, design, summary, problem;
  int exit_code = kExitOk;
  double seconds = 0;
  std::optional<double> h_lp_per_mm, v_lp_per_mm;
};

// `relative`: a chart whose group is unknown; its frequencies are then
// multiples of the largest element's (which is called G0E1, 1 "lp/mm").
std::string limit_text(const Limit& l, bool relative = false) {
  if (!l.any_resolved) return "none resolved";
  const char* unit = relative ? "x the largest element's frequency" : "lp/mm";
  std::string s = fmt::format("G{}E{} {:.2f} {}", l.group, l.element, l.lp_per_mm, unit);
  if (l.interpolated_lp_per_mm)
    s += fmt::format(" (interp. {:.2f} ± {:.2f})", *l.interpolated_lp_per_mm, l.uncertainty_lp_per_mm.value_or(0));
  else if (l.beyond_finest)  // a lower bound: finer elements may be unmeasured (a chart's failed fits)
    s += " (all measured resolved)";
  if (!l.bridged.empty()) {
    std::vector<std::string> names;
    for (const Limit::Bridged& b : l.bridged) names.push_back(fmt::format("G{}E{}", b.group, b.element));
    s += fmt::format(" [across unmeasured {}]", fmt::join(names, ", "));
  }
  return s;
}

// The reported limit, and what limits it when that is the light, not the optics.
std::string parts_text(const LimitBreakdown& p, bool relative = false) {
  std::string s = limit_text(p.reported(), relative);
  if (p.limited_by == LimitingFactor::light_noise) {
    const Limit& o = p.optical;
    s += o.any_resolved ? fmt::format(" [limited by light/noise; optics alone G{}E{}{}]", o.group, o.element,
                                      o.interpolated_lp_per_mm ? fmt::format(" {:.2f}", *o.interpolated_lp_per_mm) : "")
                        : " [limited by light/noise]";
  }
  return s;
}

std::string chart_anchor_text(const ChartDetection& d) {
  if (d.single_pattern && d.anchor == ChartAnchor::none)
    return "none (a single three-bar pattern; its orientation is the image's)";
  if (d.anchor == ChartAnchor::none)
    return d.arrangement.recognised
               ? "none (arrangement recognised but no group label read: the group is known modulo 2 only)"
               : "none (arrangement not recognised)";
  const ChartElement* largest = largest_found(d);
  const std::string found =
      largest ? fmt::format("largest element found = G{}E{}", largest->group, largest->element) : "no element";
  switch (d.anchor) {
    case ChartAnchor::arrangement:
      return fmt::format("the arrangement ({}group labels read; {})", d.arrangement.mirrored ? "mirrored; " : "",
                         found);
    case ChartAnchor::largest_group: return "--largest-group (" + found + ")";
    case ChartAnchor::printed_numbers: return "the printed numbers (" + found + ")";
    case ChartAnchor::px_per_mm: return "--px-per-mm (" + found + ")";
    case ChartAnchor::none: break;
  }
  return "none";
}

// The limit used against --require-*: interpolated when there is one.
std::optional<double> gate_value(const Limit& l) {
  if (!l.any_resolved) return 0.0;
  return l.interpolated_lp_per_mm.value_or(l.lp_per_mm);
}

// The one-line summary, the gate values and the exit code of a usable
// measurement (`chart` is null in layout mode).
void summarise(const Args& a, const Measurement& m, const ChartDetection* chart, const MeasureOptions& options,
               const LoadedImage& image, Outcome& o) {
  if (chart && chart->anchor == ChartAnchor::none && (a.require_h || a.require_v)) {
    o.exit_code = kExitUnusableInput;
    o.problem =
        "the chart's group is unknown (see the anchor in the JSON), so --require-h/-v cannot "
        "be checked in lp/mm: give --largest-group G [--largest-element E] or --px-per-mm";
    o.summary = fmt::format("RELATIVE: {}: unusable for the requirement: {}", o.design, o.problem);
    return;
  }
  o.h_lp_per_mm = gate_value(m.horizontal);
  o.v_lp_per_mm = gate_value(m.vertical);
  int ok = 0, other = 0, poor = 0;
  for (const ElementResult& e : m.elements) {
    (e.status == ElementStatus::ok ? ok : other)++;
    // Misfit only: other notes (a clipped bin, a flat gap) are in the JSON.
    poor += e.status == ElementStatus::ok && e.chi2_reduced > options.poor_fit_chi2;
  }
  std::string spec;
  std::vector<std::string> below;
  if (a.require_h && *o.h_lp_per_mm < *a.require_h)
    below.push_back(fmt::format("H {:.2f} < {:.2f}", *o.h_lp_per_mm, *a.require_h));
  if (a.require_v && *o.v_lp_per_mm < *a.require_v)
    below.push_back(fmt::format("V {:.2f} < {:.2f}", *o.v_lp_per_mm, *a.require_v));
  if (!below.empty()) {
    o.exit_code = kExitBelowSpec;
    o.problem = fmt::format("below spec: {}", fmt::join(below, ", "));
    spec = " [BELOW SPEC: " + fmt::format("{}", fmt::join(below, ", ")) + "]";
  } else if (a.require_h || a.require_v) {
    spec = " [within spec]";
  }
  const std::string counts = fmt::format("{} element{} ok, {} graded", ok, ok == 1 ? "" : "s", other);
  if (chart) {
    const bool relative = chart->anchor == ChartAnchor::none;
    // An orientation with no pattern at all (a single-pattern frame) is not
    // "none resolved": nothing of it was in view.
    auto chart_parts = [&](const LimitBreakdown& p, BarOrientation o) {
      const bool seen = std::any_of(m.elements.begin(), m.elements.end(),
                                    [&](const ElementResult& e) { return e.orientation == o; });
      return seen ? parts_text(p, relative) : std::string("no pattern in view");
    };
    o.summary = fmt::format("{}{}: H {}; V {}; {}; chart {}, anchor: {}{}{}",
                            relative ? "RELATIVE: " : "", o.design,
                            chart_parts(m.horizontal_parts, BarOrientation::horizontal_bars),
                            chart_parts(m.vertical_parts, BarOrientation::vertical_bars), counts,
                            chart->light_bars ? "negative" : "positive",
                            chart_anchor_text(*chart),
                            relative ? " (group unknown: indices count from the largest element found, called G0E1)"
                                     : "",
                            spec);
  } else {
    o.summary = fmt::format("{}: H {}; V {}; {}{}{}", o.design, parts_text(m.horizontal_parts),
                            parts_text(m.vertical_parts), counts,
                            m.distortion_corrected ? "" : "; distortion NOT corrected", spec);
  }
  // How the pixels were read, and what to check: part of every answer.
  o.summary += fmt::format("; pixels {} ({}{})", m.transfer.curve.name(), m.transfer.reason,
                           image.turned_upright
                               ? fmt::format("; turned as shown, Orientation tag {}", image.orientation)
                               : "");
  if (poor > 0) o.summary += fmt::format("; {} ok element(s) fit poorly (see their notes)", poor);
  for (const std::string& w : m.warnings) o.summary += "\n  warning: " + w;
}

struct OutputPaths {
  fs::path json, csv, overlay;  // empty: not written
  std::vector<fs::path> all() const { return {json, csv, overlay}; }
};

// In a batch (or with --out-dir) every capture's outputs go to the folder,
// named after the capture; otherwise where -o/--csv/--overlay say.
OutputPaths output_paths(const Args& a, const std::string& image_path, bool batch) {
  if (!batch && a.out_dir.empty()) return {a.output, a.csv, a.overlay};
  if (a.out_dir.empty()) return {};  // a batch gated by --junit alone
  const fs::path dir = a.out_dir;
  const std::string stem = fs::path(image_path).stem().string();
  return {dir / (stem + ".json"), dir / (stem + ".csv"), dir / (stem + ".overlay.png")};
}

// `layout` is null in chart mode.
Outcome measure_one(const Args& a, const std::string& image_path, const TargetLayout* layout,
                    const std::string& layout_sha1, const CameraModel* camera, const MeasureOptions& options,
                    bool batch) {
  Outcome o;
  o.image = image_path;
  o.design = a.design.empty() || batch ? fs::path(image_path).stem().string() : a.design;
  const auto t0 = std::chrono::steady_clock::now();
  const OutputPaths out = output_paths(a, image_path, batch);
  const fs::path &json_path = out.json, &csv_path = out.csv, &overlay_path = out.overlay;
  LoadOptions lo;
  lo.channel = a.channel;
  lo.transfer = transfer_from_option(a.transfer);
  lo.non_finite = non_finite_policy_from_string(a.non_finite);
  lo.upright = layout == nullptr;  // chart mode: H and V as a person sees the file

  MeasurementContext ctx;
  ctx.image = image_path;
  ctx.design = o.design;
  ctx.layout = layout ? a.layout : "chart:" + a.chart;
  ctx.layout_sha1 = layout_sha1;
  ctx.tactres_version = TACTRES_VERSION;
  ctx.options = &options;

  Measurement m;
  std::optional<ChartDetection> chart;
  LoadedImage img;
  try {
    const auto td = std::chrono::steady_clock::now();
    img = load_image(image_path, lo);
    ctx.decode_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - td).count();
    ctx.loaded = &img;
    if (layout) {
      m = measure_capture(img, *layout, camera, options);
    } else {
      ChartMeasureOptions co;
      co.measure = options;
      co.detect.largest_group = a.largest_group;
      co.detect.largest_element = a.largest_element;
      co.detect.px_per_mm = a.px_per_mm;
      ChartMeasurement cm = measure_chart(img, co);
      m = std::move(cm.measurement);
      chart = std::move(cm.detection);
    }
  } catch (const UnusableInput& e) {
    m.usable = false;
    m.problem = e.what();
  } catch (const std::exception& e) {  // a missing file, a camera model for another imager
    o.exit_code = kExitUsageOrIo;
    o.problem = e.what();
    o.summary = fmt::format("{}: error: {}", o.design, e.what());
    // In a batch's folder the failure gets its JSON too, so that a report
    // of the folder shows it as failed instead of leaving it out.
    if (!a.out_dir.empty() && !json_path.empty()) {
      m.usable = false;
      m.problem = e.what();
      try {
        AtomicOutputSet failed;  // and no earlier CSV or overlay of its name stays beside it
        failed.stage_bytes(json_path, json_text(measurement_to_json(m, ctx)) + "\n");
        for (const fs::path& p : {csv_path, overlay_path}) failed.stage_removal(p);
        failed.commit();
      } catch (const std::exception& w) {  // the capture's own error stays the news
        o.problem += std::string("; and its JSON could not be written: ") + w.what();
        o.summary = fmt::format("{}: error: {}", o.design, o.problem);
      }
    }
    return o;
  }

  // Said whether or not the first frame was usable: a stack whose first
  // frame is blank is where the hint matters most.
  if (img.more_frames)
    m.warnings.push_back("the file holds more images of this size (frames of a stack); only the first was "
                         "measured: save the frame to measure on its own");

  // Outputs, all or none (util/atomic_file.h); their folders are made. An
  // unusable capture still gets its JSON, which says why, so that reports
  // show it as failed instead of dropping it.
  AtomicOutputSet outputs;
  ctx.chart = chart ? &*chart : nullptr;
  if (!json_path.empty()) outputs.stage_bytes(json_path, json_text(measurement_to_json(m, ctx)) + "\n");
  if (m.usable || (chart && !m.elements.empty())) {
    if (!csv_path.empty()) outputs.stage_bytes(csv_path, measurement_csv_header() + measurement_csv_rows(m, ctx));
    if (!overlay_path.empty())
      outputs.stage(overlay_path, [&](const fs::path& p) { write_image(p, overlay_image(img.luminance, m)); });
  } else {
    // Nothing to tabulate or draw: an earlier run's CSV and overlay of this
    // name go, or they would read as this capture's.
    for (const fs::path& p : {csv_path, overlay_path})
      if (!p.empty()) outputs.stage_removal(p);
  }
  outputs.commit();
  o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  if (!m.usable) {
    o.exit_code = kExitUnusableInput;
    o.problem = m.problem;
    o.summary = fmt::format("{}: unusable: {}", o.design, m.problem);
    for (const std::string& w : m.warnings) o.summary += "\n  warning: " + w;
    return o;
  }
  summarise(a, m, chart ? &*chart : nullptr, options, img, o);
  return o;
}

// Text for an XML attribute: markup escaped, bytes that are not UTF-8 and
// the control characters XML 1.0 forbids even escaped replaced by U+FFFD
// (a design label or file name may hold either).
std::string xml_escape(const std::string& s) {
  std::string out;
  for (char c : valid_utf8(s)) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\t': out += "&#9;"; break;
      case '\n': out += "&#10;"; break;
      case '\r': out += "&#13;"; break;
      default: out += static_cast<unsigned char>(c) < 0x20 ? std::string("\xEF\xBF\xBD") : std::string(1, c);
    }
  }
  return out;
}

std::string junit_xml(const std::vector<Outcome>& outcomes) {
  int failures = 0, errors = 0;
  std::string cases;
  for (const Outcome& o : outcomes) {
    cases += fmt::format("    <testcase classname=\"tactres.measure\" name=\"{}\" time=\"{:.3f}\">\n",
                         xml_escape(o.design), o.seconds);
    if (o.exit_code == kExitBelowSpec) {
      ++failures;
      cases += fmt::format("      <failure message=\"{}\"/>\n", xml_escape(o.problem));
    } else if (o.exit_code != kExitOk) {
      ++errors;
      cases += fmt::format("      <error message=\"{}\"/>\n", xml_escape(o.problem));
    }
    cases += fmt::format("      <system-out>{}</system-out>\n    </testcase>\n", xml_escape(o.summary));
  }
  return fmt::format(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuites>\n  <testsuite name=\"tactres measure\" "
      "tests=\"{}\" failures=\"{}\" errors=\"{}\">\n{}  </testsuite>\n</testsuites>\n",
      outcomes.size(), failures, errors, cases);
}

}  // namespace

// The command line: every option with its unit, range and default.
void add_measure_options(CLI::App& app, Args& a) {
  app.add_option("images", a.images, "Capture(s): any format OpenImageIO reads (PNG, TIFF, EXR, JPEG...)")
      ->required();
  auto* layout_opt = app.add_option("--layout", a.layout,
                                    "Layout JSON of the captured target (from `tactres generate`); "
                                    "not with --chart");
  auto* chart_opt = app.add_option("--chart", a.chart,
                                   "Measure a standard USAF-1951 chart (MIL-STD-150A) found in the image, "
                                   "with no layout and no fiducials (docs/CHART.md)")
                        ->check(CLI::IsMember({"usaf1951"}))
                        ->excludes(layout_opt);
  auto* lg = app.add_option("--largest-group", a.largest_group,
                            "Chart mode anchor: the largest element found belongs to this group (-10..12)")
                 ->needs(chart_opt);
  app.add_option("--largest-element", a.largest_element,
                 "With --largest-group: which element of it the largest one found is (1..6)")
      ->capture_default_str()
      ->check(CLI::Range(1, 6))
      ->needs(lg);
  app.add_option("--px-per-mm", a.px_per_mm,
                 "Chart mode anchor: image scale at the chart plane in px/mm (the largest element's "
                 "frequency follows from its period)")
      ->needs(chart_opt)
      ->excludes(lg);
  app.add_option("--camera", a.camera,
                 "mrcal .cameramodel of the camera (default: a pinhole fitted from the fiducials, "
                 "distortion not corrected)");
  app.add_option("--design", a.design, "Design label for a single image (default: the file's stem)");
  app.add_option("-o,--output", a.output, "Measurement JSON (single image)");
  app.add_option("--csv", a.csv, "Per-element CSV (single image)");
  app.add_option("--overlay", a.overlay, "Overlay PNG of the sampled strips coloured by status (single image)");
  app.add_option("--out-dir", a.out_dir,
                 "Batch: write <stem>.json, <stem>.csv and <stem>.overlay.png here for every image");
  app.add_option("--threshold", a.threshold, "Criterion: m(f) at the limit, in (0, 1)")
      ->capture_default_str()
      ->check(CLI::Range(0.001, 0.999));
  app.add_option("--detectability-k", a.detectability_k,
                 "Rose threshold: an element is detectable when its bars' contrast-to-noise ratio over one bar's "
                 "pixels is >= k, in [1, 100] (docs/CONVENTIONS.md, \"Two limits\")")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 100.0));
  app.add_option("--preset", a.preset, "Accuracy/time trade: fast, balanced or precise")
      ->capture_default_str()
      ->check(CLI::IsMember({"fast", "balanced", "precise"}));
  // A spec must be a real frequency: NaN compares false with every limit
  // and would pass any capture.
  const auto spec_lp_per_mm = [](const std::string& text) {
    size_t used = 0;
    double v = std::numeric_limits<double>::quiet_NaN();
    try {
      v = std::stod(text, &used);
    } catch (const std::exception&) {
    }
    return used == text.size() && std::isfinite(v) && v > 0 && v <= 1e4
               ? std::string()
               : "must be a frequency in lp/mm, > 0 and <= 10000 (got " + text + ")";
  };
  app.add_option("--require-h", a.require_h,
                 "Exit 1 if the reported horizontal-bar limit (interpolated, lp/mm; the coarser of optics and "
                 "detectability) is below this; lp/mm in (0, 10000]")
      ->check(spec_lp_per_mm);
  app.add_option("--require-v", a.require_v,
                 "Exit 1 if the reported vertical-bar limit (interpolated, lp/mm; the coarser of optics and "
                 "detectability) is below this; lp/mm in (0, 10000]")
      ->check(spec_lp_per_mm);
  app.add_option("--junit", a.junit, "Write JUnit XML: one test case per image (enough output by itself)");
  app.add_option("--channel", a.channel, "Channel to measure, -1..63 (default -1: Rec. 709 luminance)")
      ->capture_default_str();
  app.add_option("--transfer", a.transfer, "How the file's code values map to light: auto (the file's colour tag; without one, 8-bit = "
                 "sRGB, 16-bit and float = linear), linear, srgb, or gamma:G (light = code^G, G in [0.2, 5])")
      ->capture_default_str()
      ->check([](const std::string& text) {
        try {
          transfer_from_option(text);
          return std::string();
        } catch (const std::invalid_argument& e) {
          return std::string(e.what());
        }
      });
  app.add_option("--non-finite", a.non_finite, "NaN/Inf pixels: mask (skip them) or reject the image")
      ->capture_default_str()
      ->check(CLI::IsMember({"mask", "reject"}));
  app.add_option("--signature", a.signature,
                 "Profile model: albedo (printed bars), shading (relief through a gel) or auto")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "albedo", "shading"}));
  app.add_option("--min-px-per-bar", a.min_px_per_bar,
                 "Below this many pixels per bar an element is below_sampling_limit (default 1.25: 0.8 of Nyquist); "
                 "with --chart, unless its profile plainly shows all three bars")
      ->check(CLI::Range(0.5, 20.0));
  app.add_option("-j,--jobs", a.jobs, "Batch: images measured in parallel, 0..256 (default 0: all cores)")
      ->check(CLI::Range(0, 256));
}

// The analysis options the arguments ask for, validated; throws
// std::invalid_argument (exit 3) for a combination that cannot work.
MeasureOptions measure_options(const Args& a, bool batch) {
  if (!batch && a.output.empty() && a.csv.empty() && a.overlay.empty() && a.out_dir.empty() && a.junit.empty())
    throw std::invalid_argument(
        "say where results go: -o result.json (and/or --csv, --overlay, --junit), or --out-dir DIR");
  if (batch && (!a.output.empty() || !a.csv.empty() || !a.overlay.empty()))
    throw std::invalid_argument("several images need --out-dir DIR instead of -o/--csv/--overlay");
  if (batch && a.out_dir.empty() && a.junit.empty())
    throw std::invalid_argument("several images need --out-dir DIR (or --junit FILE alone, for a CI gate)");
  if (!a.out_dir.empty()) {
    std::map<std::string, std::string> by_stem;
    for (const std::string& image : a.images) {
      const auto [it, fresh] = by_stem.emplace(fs::path(image).stem().string(), image);
      if (!fresh)
        throw std::invalid_argument("two captures, " + it->second + " and " + image + ", would both write " +
                                    it->first + ".json into --out-dir: rename one, or measure them in two runs");
    }
  }
  // Two outputs on one path would overwrite each other unsaid, and an
  // output on an input would destroy it (the overlay over its capture).
  std::vector<fs::path> outputs = {a.output, a.csv, a.overlay, a.junit}, inputs = {a.layout, a.camera};
  for (const std::string& image : a.images) {
    inputs.emplace_back(image);
    if (!a.out_dir.empty())
      for (const fs::path& p : output_paths(a, image, batch).all()) outputs.push_back(p);
  }
  refuse_colliding_outputs(outputs, inputs);
  MeasureOptions options = MeasureOptions::for_preset(preset_from_string(a.preset));
  options.criterion.threshold = a.threshold;
  options.detectability.k = a.detectability_k;
  options.signature = a.signature;
  if (a.min_px_per_bar) options.min_px_per_bar = *a.min_px_per_bar;
  options.validate();
  if (a.chart.empty() && a.layout.empty())
    throw std::invalid_argument("give the target: --layout layout.json, or --chart usaf1951 for a standard chart");
  if (!a.chart.empty() && !a.camera.empty())
    throw std::invalid_argument("--camera does not apply to --chart: chart mode measures each pattern in its own frame");
  return options;
}

// Measures every image (in parallel, one bad file never stops the others),
// prints one summary line each and returns the worst exit code.
int run_measure(const Args& a) {
  const bool batch = a.images.size() > 1 || !a.out_dir.empty();
  const MeasureOptions options = measure_options(a, batch);
  std::optional<TargetLayout> layout;
  std::string layout_sha1;
  if (a.chart.empty()) layout = read_layout_file(a.layout), layout_sha1 = file_sha1(a.layout);
  std::optional<CameraModel> camera;
  if (!a.camera.empty()) camera = CameraModel::load(a.camera);
  // Every folder an output needs, made before anything is measured.
  for (const fs::path& dir : {fs::path(a.out_dir), fs::path(a.junit).parent_path()}) {
    std::error_code ec;
    if (!dir.empty()) fs::create_directories(dir, ec);
    if (ec) throw std::runtime_error("cannot create " + dir.string() + ": " + ec.message());
  }

  std::vector<Outcome> outcomes(a.images.size());
  std::atomic<size_t> done{0};
  std::mutex print;
  const bool tty = isatty(fileno(stderr)) && batch;
  for_each_index(a.images.size(), a.jobs, [&](size_t i) {
      try {
        outcomes[i] = measure_one(a, a.images[i], layout ? &*layout : nullptr, layout_sha1, camera ? &*camera : nullptr,
                                  options, batch);
      } catch (const std::exception& e) {  // an output could not be written
        outcomes[i].image = a.images[i];
        outcomes[i].design = fs::path(a.images[i]).stem().string();
        outcomes[i].exit_code = kExitUsageOrIo;
        outcomes[i].problem = e.what();
        outcomes[i].summary = fmt::format("{}: error: {}", outcomes[i].design, e.what());
      }
      const size_t n = ++done;
      if (tty) {
        std::lock_guard<std::mutex> lock(print);
        const int width = 30, filled = int(width * n / a.images.size());
        fmt::print(stderr, "\r[{}{}] {}/{} {}", std::string(filled, '#'), std::string(width - filled, ' '),
                   n, a.images.size(), n == a.images.size() ? "\n" : "");
      }
  });

  int worst = kExitOk;
  int by_code[4] = {0, 0, 0, 0};
  for (const Outcome& o : outcomes) {
    const bool measured = o.exit_code == kExitOk || o.exit_code == kExitBelowSpec;
    fmt::print(measured ? stdout : stderr, "{}\n", o.summary);
    worst = std::max(worst, o.exit_code);
    ++by_code[std::clamp(o.exit_code, 0, 3)];
  }
  if (!a.junit.empty()) write_file_atomically(a.junit, junit_xml(outcomes));
  // A batch's exit code is its worst capture's (README, "Exit codes").
  if (batch)
    fmt::print("{} capture(s): {} measured ({} below spec), {} unusable, {} error(s); exit {}\n", outcomes.size(),
               by_code[kExitOk] + by_code[kExitBelowSpec], by_code[kExitBelowSpec], by_code[kExitUnusableInput],
               by_code[kExitUsageOrIo], worst);
  return worst;
}

Command measure_command() {
  return {"measure", "Measure captures: lp/mm per orientation with uncertainty, JSON/CSV/overlay, CI exit codes",
          [](CLI::App& app) -> std::function<int()> {
            auto a = std::make_shared<Args>();
            add_measure_options(app, *a);
            return [a]() { return run_measure(*a); };
          }};
}

}  // namespace tactres::cli
