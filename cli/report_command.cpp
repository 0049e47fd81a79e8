// `tactres report`: designs against the bare camera, as CSV and one
// self-contained HTML file.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>

#include <fmt/format.h>

#include "command.h"
#include "exit_codes.h"
#include "tactres/reports/comparison.h"
#include "tactres/reports/report_csv.h"
#include "tactres/reports/report_html.h"
#include "tactres/util/atomic_file.h"

namespace tactres::cli {
namespace {

namespace fs = std::filesystem;

struct Args {
  std::vector<std::string> results;
  std::string reference, html, csv;
  std::string chart_js = kDebianChartJsPath;
  int thumbnail_px = 640;
};

// Both outputs are rendered in memory first and then moved into place, so
// that a refusal or a rendering error leaves no report (and no half of one).
void write_outputs(const std::vector<std::pair<fs::path, std::string>>& outputs) {
  std::vector<std::unique_ptr<AtomicOutput>> pending;
  for (const auto& [path, bytes] : outputs) {
    pending.push_back(std::make_unique<AtomicOutput>(path));
    std::ofstream f(pending.back()->temp_path(), std::ios::binary | std::ios::trunc);
    if (!f) throw std::runtime_error("cannot write " + path.string() + ": the folder is missing or not writable");
    f.write(bytes.data(), std::streamsize(bytes.size()));
    f.flush();
    if (!f) throw std::runtime_error("cannot write " + path.string() + ": write failed (disk full?)");
  }
  for (auto& p : pending) p->commit();
}

std::string limit_summary(const OrientationSummary& o) {
  const auto v = o.value_lp_per_mm();
  if (!v) return "none resolved";
  std::string s = fmt::format("{:.2f}", *v);
  if (o.interp_sigma_lp_per_mm) s += fmt::format(" ± {:.2f}", *o.interp_sigma_lp_per_mm);
  if (o.pct_of_reference) s += fmt::format(" ({:.0f}%)", *o.pct_of_reference);
  return s;
}

}  // namespace

Command report_command() {
  return {"report", "Compare designs against the bare camera (raw CMOS limit): CSV and one offline HTML file",
          [](CLI::App& app) -> std::function<int()> {
            auto a = std::make_shared<Args>();
            app.add_option("results", a->results,
                           "Measurement JSONs of the designs (from `tactres measure`); presses with the same design "
                           "label are aggregated (mean ± sample SD)");
            app.add_option("--reference", a->reference,
                           "Measurement JSON of the bare camera: percentages are of its limits (lp/mm), and the "
                           "camera's sampling (Nyquist) limit comes from it. Required");
            app.add_option("--html", a->html, "Write the self-contained HTML report here (opens offline)");
            app.add_option("--csv", a->csv, "Write the table here as CSV: one row per design plus the reference "
                                            "(columns in docs/REPORT.md)");
            app.add_option("--chart-js", a->chart_js, "Chart.js (UMD build) to inline into the HTML")
                ->capture_default_str();
            app.add_option("--thumbnail-px", a->thumbnail_px,
                           "Long side of the overlay thumbnails in the HTML, in pixels, 32..4096 (larger overlays "
                           "are downscaled)")
                ->capture_default_str();
            app.footer(
                "Each measurement's overlay is read from <stem>.overlay.png beside <stem>.json (measure --out-dir "
                "writes it there); a missing one is shown as missing. Limits are in lp/mm at the target plane.\n"
                "Example: tactres report out/T*.json --reference out/cmos.json --html report.html --csv report.csv");
            return [a]() {
              if (a->html.empty() && a->csv.empty())
                throw std::invalid_argument("say where the report goes: --html report.html and/or --csv report.csv");
              // An output over an input (a measurement, the reference)
              // would destroy it.
              std::vector<fs::path> inputs(a->results.begin(), a->results.end());
              inputs.insert(inputs.end(), {a->reference, a->chart_js});
              refuse_colliding_outputs({a->html, a->csv}, inputs);
              HtmlReportOptions html_options;
              html_options.chart_js = a->chart_js;
              html_options.thumbnail_max_px = a->thumbnail_px;
              html_options.tactres_version = TACTRES_VERSION;
              html_options.validate();

              std::vector<fs::path> files(a->results.begin(), a->results.end());
              const Comparison c = load_comparison(files, a->reference);

              std::vector<std::pair<fs::path, std::string>> outputs;
              if (!a->csv.empty()) outputs.emplace_back(a->csv, report_csv(c));
              if (!a->html.empty()) outputs.emplace_back(a->html, render_html_report(c, html_options));
              write_outputs(outputs);

              int failed = 0;
              for (const DesignRow& r : c.designs) failed += r.status == RowStatus::failed;
              fmt::print("{} design(s) from {} measurement(s) against the reference {} ({}){}\n", c.designs.size(),
                         c.measurements.size(), c.reference_row.design, c.reference.path.string(),
                         failed ? fmt::format("; {} failed", failed) : "");
              fmt::print("  {:<4} {:<16} {:>26} {:>26}  {}\n", "rank", "design", "H lp/mm (% raw CMOS)",
                         "V lp/mm (% raw CMOS)", "limited by H/V; light needed");
              fmt::print("  {:<4} {:<16} {:>26} {:>26}\n", "ref", c.reference_row.design,
                         limit_summary(c.reference_row.horizontal), limit_summary(c.reference_row.vertical));
              for (const DesignRow& r : c.designs) {
                if (r.status == RowStatus::failed) {
                  fmt::print("  {:<4} {:<16} failed: {}\n", "-", r.design, r.problems.empty() ? "" : r.problems[0]);
                  continue;
                }
                auto factor = [](const OrientationParts& p) {
                  return p.limited_by == LimitedBy::unknown ? "n/a" : to_string(p.limited_by);
                };
                fmt::print("  {:<4} {:<16} {:>26} {:>26}  {}/{}; {}\n", r.rank ? std::to_string(*r.rank) : "-",
                           r.design, limit_summary(r.horizontal), limit_summary(r.vertical), factor(r.horizontal_parts),
                           factor(r.vertical_parts), light_needed_text(r.light_needed_factor));
              }
              if (c.nyquist_h_lp_per_mm > 0)
                fmt::print("  camera sampling (Nyquist) limit: H {:.2f}, V {:.2f} lp/mm\n", c.nyquist_h_lp_per_mm,
                           c.nyquist_v_lp_per_mm);
              if (!a->html.empty()) fmt::print("HTML: {}\n", a->html);
              if (!a->csv.empty()) fmt::print("CSV: {}\n", a->csv);
              return int(kExitOk);
            };
          }};
}

}  // namespace tactres::cli
