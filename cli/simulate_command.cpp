// `tactres simulate`: render a scene into a capture plus its truth file.
#include <algorithm>
#include <chrono>
#include <filesystem>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "command.h"
#include "exit_codes.h"
#include "tactres/util/json_fields.h"
#include "tactres/camera/camera_model.h"
#include "tactres/camera/image_io.h"
#include "tactres/simulate/renderer.h"
#include "tactres/simulate/scene.h"
#include "tactres/simulate/truth.h"
#include "tactres/util/atomic_file.h"
#include "tactres/targets/layout.h"
#include "tactres/targets/layout_json.h"

namespace tactres::cli {

namespace {
constexpr const char* kDefaultTargetName = "the default target (`tactres generate` with default options)";
}  // namespace

Command simulate_command() {
  return {"simulate", "Render a scene: the capture a sensor and camera would record, plus its truth file",
          [](CLI::App& app) -> std::function<int()> {
            struct Args {
              std::string scene, output, truth, layout;
              std::optional<std::uint64_t> seed;
              int supersampling = 0;
            };
            auto a = std::make_shared<Args>();
            app.add_option("scene", a->scene, "Scene file (JSON, schema tactres.scene/1; see docs/FORMATS.md)")
                ->required();
            app.add_option("-o,--output", a->output,
                           "Capture to write: .png (needs a sensor effect), .tif/.tiff or .exr (float)")
                ->required();
            app.add_option("--truth", a->truth, "Truth file to write (default: <capture>.truth.json)");
            app.add_option("--layout", a->layout,
                           "Layout JSON (overrides the scene's \"layout\"; with neither, the default target of "
                           "`tactres generate`)");
            app.add_option("--seed", a->seed, "Sensor noise seed (default: the sensor effect's \"seed\", 1 unless the scene says; same seed, same bytes)");
            app.add_option("--supersampling", a->supersampling,
                           "Sub-pixels per pixel side, 1..16 (overrides the scene's; default 2)")
                ->check(CLI::Range(1, 16));
            return [a]() {
              Scene scene = read_scene_file(a->scene);
              if (a->supersampling > 0) scene.supersampling = a->supersampling;
              if (!a->layout.empty()) scene.layout_path = a->layout;
              // No layout given: the default target, exactly as `tactres
              // generate` makes it with default options, so that the shipped
              // scenes run as they are.
              const TargetLayout layout =
                  scene.layout_path ? read_layout_file(*scene.layout_path) : make_layout(LayoutOptions{});
              const std::string layout_source =
                  scene.layout_path ? scene.layout_path->string()
                                    : std::string(kDefaultTargetName);
              // A scene's paths are relative to its own folder: say so when
              // the camera is not there.
              if (std::error_code ec; !std::filesystem::is_regular_file(scene.camera_path, ec))
                throw std::runtime_error(fmt::format(
                    "cannot read the scene's \"camera\" {}: no such file (a scene's paths are relative to the "
                    "scene file's folder)",
                    scene.camera_path.string()));
              const CameraModel camera = CameraModel::load(scene.camera_path);
              const std::filesystem::path out(a->output);
              const std::filesystem::path truth_path =
                  a->truth.empty() ? std::filesystem::path(out.string() + ".truth.json") : std::filesystem::path(a->truth);
              // An output over an input (the scene, its layout or camera)
              // would destroy it.
              refuse_colliding_outputs({out, truth_path},
                                       {a->scene, scene.layout_path.value_or(""), scene.camera_path});
              std::string ext = out.extension().string();
              std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
              // The truth describes the pixels exactly as rendered: a lossy
              // or 8-bit-only format (JPEG, BMP) would change them unsaid.
              if (ext != ".png" && ext != ".tif" && ext != ".tiff" && ext != ".exr")
                throw std::invalid_argument(fmt::format(
                    "cannot write a capture as '{}': use .png (needs a sensor effect), .tif/.tiff or .exr; a lossy "
                    "or 8-bit-only format would change the pixels the truth file describes",
                    ext.empty() ? out.filename().string() : ext));
              if (!scene.find<SensorOptions>() && ext == ".png")
                throw std::invalid_argument(
                    "an ideal (float) render needs .tif or .exr; add a sensor effect to write .png");

              const auto t0 = std::chrono::steady_clock::now();
              const Truth truth = compute_truth(scene, layout, camera);
              // A capture with no element in view (a target behind the
              // camera, or offset off the sensor) would be a black frame
              // whose truth holds nothing to measure.
              if (std::none_of(truth.elements.begin(), truth.elements.end(),
                               [](const TruthElement& e) { return e.in_view; }))
                throw std::invalid_argument(fmt::format(
                    "the scene puts no element of the target in full view of the {}x{} camera: check its pose "
                    "(the target must lie in front of the camera, +z, within its field: distance_mm, offset_mm, "
                    "rt_camera_from_target)",
                    camera.imager_width(), camera.imager_height()));
              const RenderResult r = render_scene(scene, layout, camera, a->seed);
              const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

              // The capture and its truth, both or neither; their folders
              // are made when missing (util/atomic_file.h).
              nlohmann::json tj = truth_to_json(truth, scene, out.filename().string());
              tj["layout"] = layout_source;
              AtomicOutputSet outputs;
              outputs.stage(out, [&](const std::filesystem::path& p) { write_image(p, r.image, r.bits); });
              outputs.stage_bytes(truth_path, json_text(tj) + "\n");
              outputs.commit();

              // The reported (coarser) true limit, and when the light limits it.
              auto limit_text = [](const LimitBreakdown& parts) {
                const Limit& l = parts.reported();
                const std::string by =
                    parts.limited_by == LimitingFactor::light_noise ? " [limited by light/noise]" : "";
                if (!l.any_resolved) return "none resolved" + by;
                return fmt::format("G{}E{} {:.2f} lp/mm (interpolated {}){}", l.group, l.element, l.lp_per_mm,
                                   l.interpolated_lp_per_mm ? fmt::format("{:.2f}", *l.interpolated_lp_per_mm)
                                                            : std::string("n/a"),
                                   by);
              };
              fmt::print("{}: {} {}x{} in {:.2f} s; true limit H {}, V {}; truth {}{}\n", scene.design,
                         out.string(), r.image.cols, r.image.rows, seconds, limit_text(truth.horizontal_parts),
                         limit_text(truth.vertical_parts), truth_path.string(),
                         scene.layout_path ? "" : fmt::format("; layout: {}", layout_source));
              return int(kExitOk);
            };
          }};
}

}  // namespace tactres::cli
