// `tactres generate`: the USAF-1951-style target in every output format.
#include <filesystem>

#include <fmt/format.h>

#include "command.h"
#include "exit_codes.h"
#include "tactres/targets/layout.h"
#include "tactres/targets/layout_json.h"

namespace tactres::cli {

Command generate_command() {
  return {"generate", "Write the target: layout JSON, SVG, raster, height map and STL relief",
          [](CLI::App& app) -> std::function<int()> {
            struct Args {
              std::string out_dir;
              LayoutOptions layout;
            };
            auto a = std::make_shared<Args>();
            app.add_option("--out,-o", a->out_dir, "Output folder (created if missing)")->required();
            app.add_option("--first-group", a->layout.first_group, "Coarsest USAF group")
                ->capture_default_str();
            app.add_option("--last-group", a->layout.last_group, "Finest USAF group (>= first)")
                ->capture_default_str();
            return [a]() {
              a->layout.validate();
              const TargetLayout layout = make_layout(a->layout);
              std::filesystem::create_directories(a->out_dir);
              write_layout_file(std::filesystem::path(a->out_dir) / "layout.json", layout);
              return int(kExitOk);
            };
          }};
}

}  // namespace tactres::cli
