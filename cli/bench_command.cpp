// `tactres bench`: what accuracy costs in time, on scenes with known truth.
#include <cstdio>

#include <fmt/format.h>

#include "command.h"
#include "exit_codes.h"
#include "tactres/bench/bench.h"

namespace tactres::cli {

Command bench_command() {
  return {"bench",
          "Time and accuracy of every preset and setting on a fixed suite of simulated captures with known truth",
          [](CLI::App& app) -> std::function<int()> {
            struct Args {
              bool quick = false, list = false, no_live = false;
              std::string out, camera;
              std::vector<std::string> scenes, settings;
            };
            auto a = std::make_shared<Args>();
            app.add_flag("--quick", a->quick, "A small subset of the suite: 12 scenes and the live figures, about 40 s on 2 cores");
            app.add_option("--out", a->out,
                           "Folder for the captures, truth files, bench.csv, bench_summary.csv, bench.html and live.csv (required; made if missing)");
            app.add_option("--camera", a->camera,
                           "mrcal .cameramodel to render and measure with (default: the built-in example "
                           "wide-angle camera, examples/cameras/wide_angle.cameramodel)");
            app.add_option("--scene", a->scenes, "Only this scene (repeatable; names: --list)");
            app.add_option("--setting", a->settings, "Only this setting (repeatable; names: --list)");
            app.add_flag("--no-live", a->no_live,
                         "Skip the live-mode figures (tactres watch per frame: from scratch, tracked, near-limit; "
                         "layout mode, and a 1.57 Mpx chart in a full run; about 20 s)");
            app.add_flag("--list", a->list, "List the suite's scenes and the settings, then exit");
            return [a]() {
              if (a->list) {
                for (const BenchScene& s : bench_suite())
                  fmt::print("scene   {}{}{}\n", s.name, s.in_quick ? "  [quick]" : "",
                             s.supersampling_sweep ? "  [supersampling sweep]" : "");
                for (const BenchSetting& s : bench_settings()) fmt::print("setting {}\n", s.name);
                return int(kExitOk);
              }
              BenchOptions o;
              o.quick = a->quick;
              o.out_dir = a->out;
              if (!a->camera.empty()) o.camera_path = a->camera;
              o.scenes = a->scenes;
              o.settings = a->settings;
              o.live = !a->no_live;
              o.validate();
              const BenchResult r = run_bench(o, [](const std::string& line) {
                fmt::print(stderr, "{}\n", line);
                std::fflush(stderr);
              });
              HtmlReportOptions html;
              html.tactres_version = TACTRES_VERSION;
              write_bench_outputs(r, o.out_dir, html);
              fmt::print("{}", bench_table_text(r));
              fmt::print("wrote {}/bench.csv, bench_summary.csv, bench.html{}\n", o.out_dir.string(),
                         r.live.empty() ? "" : ", live.csv");
              return int(kExitOk);
            };
          }};
}

}  // namespace tactres::cli
