// `tactres generate`: the USAF-1951-style target (or, with --style
// mil-std-150a, the standard chart) in every output format.
// All outputs are rendered to hidden temporary files first and renamed into
// place only when every one of them succeeded, so a failure leaves no partial
// set behind.
#include <cmath>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include <fmt/format.h>

#include "command.h"
#include "exit_codes.h"
#include "tactres/util/atomic_file.h"
#include "tactres/targets/heightmap.h"
#include "tactres/targets/layout.h"
#include "tactres/targets/layout_json.h"
#include "tactres/targets/mil_std_chart.h"
#include "tactres/targets/raster.h"
#include "tactres/targets/stl.h"
#include "tactres/targets/svg.h"
#include "tactres/targets/usaf_series.h"

namespace tactres::cli {
namespace {

namespace fs = std::filesystem;

struct GenerateArgs {
  std::string out_dir;
  LayoutOptions layout;
  std::string field_mm;  // "W" or "WxH"; overrides the separate width/height
  double px_per_mm = 40.0;
  double relief_um = 100.0;
  std::string polarity = to_string(Polarity::dark_bars_on_light);
  StlOptions stl;
  std::string style = "usaf";  // usaf (the packed tactile layout) | mil-std-150a
  bool first_given = false, last_given = false, field_given = false;
};

// "20" -> 20 x 20, "25x20" -> 25 x 20.
void parse_field(const std::string& text, LayoutOptions& o) {
  const auto bad = [&] {
    return std::invalid_argument("--field-mm expects W or WxH in mm (e.g. 20 or 25x20), got '" +
                                 text + "'");
  };
  auto number = [&](const std::string& s) {
    size_t used = 0;
    double v = 0;
    try {
      v = std::stod(s, &used);
    } catch (const std::exception&) {
      throw bad();
    }
    if (used != s.size()) throw bad();
    return v;
  };
  const size_t x = text.find_first_of("xX");
  o.field_width_mm = number(text.substr(0, x));
  o.field_height_mm = x == std::string::npos ? o.field_width_mm : number(text.substr(x + 1));
}

int run_generate(GenerateArgs a) {
  // Validate everything before touching the file system.
  if (!a.field_mm.empty()) parse_field(a.field_mm, a.layout);
  a.layout.relief_height_mm = a.relief_um / 1000.0;
  a.layout.polarity = polarity_from_string(a.polarity);
  a.stl.validate();
  TargetLayout layout;
  if (a.style == "mil-std-150a") {
    // The standard chart has its own size (the arrangement fixes it) and
    // groups -2..7 unless the user chose a range.
    if (a.field_given)
      throw std::invalid_argument(
          "--field-mm / --field-width-mm / --field-height-mm do not apply to --style mil-std-150a: the "
          "standard arrangement fixes the chart's size (group -2 makes it about 88 x 67 mm)");
    MilStdChartOptions c;
    if (a.first_given) c.first_group = a.layout.first_group;
    if (a.last_given) c.last_group = a.layout.last_group;
    c.relief_height_mm = a.layout.relief_height_mm;
    c.base_thickness_mm = a.layout.base_thickness_mm;
    c.polarity = a.layout.polarity;
    layout = make_mil_std_chart(c);
  } else {
    a.layout.validate();
    layout = make_layout(a.layout);
  }
  validate_raster_resolution(layout, a.px_per_mm);

  // Render in memory: the only failures left after this are I/O.
  const ImageF coverage = coverage_raster(layout, a.px_per_mm);
  const TriangleMesh mesh = relief_mesh(layout, a.stl);

  const fs::path dir(a.out_dir);
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
    throw std::runtime_error(fmt::format("cannot write into {}: it is a file, not a folder", dir.string()));
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir, ec))
    throw std::runtime_error(
        fmt::format("cannot create the output folder {}: {}", dir.string(), ec.message()));

  // All six or none (util/atomic_file.h).
  AtomicOutputSet outputs;
  const double ppm = a.px_per_mm;
  outputs.stage(dir / "layout.json", [&](const fs::path& p) { write_layout_file(p, layout); });
  outputs.stage(dir / "target.svg", [&](const fs::path& p) { write_target_svg(p, layout); });
  outputs.stage(dir / "target.png", [&](const fs::path& p) { write_target_png8(p, coverage, layout.polarity, ppm); });
  outputs.stage(dir / "target.tif", [&](const fs::path& p) { write_target_tiff16(p, coverage, layout.polarity, ppm); });
  outputs.stage(dir / "height.tif", [&](const fs::path& p) { write_height_map_tiff(p, layout, coverage, ppm); });
  outputs.stage(dir / "relief.stl", [&](const fs::path& p) { write_binary_stl(p, mesh); });
  outputs.commit();

  const int w = coverage.width, h = coverage.height;
  fmt::print("tactres generate: wrote {} files to {}\n", outputs.size(), dir.string());
  fmt::print("  layout.json, target.svg, target.png (8-bit), target.tif (16-bit), "
             "height.tif (float, mm), relief.stl\n");
  fmt::print("  {}, field {:g} x {:g} mm, groups {}..{} ({:.3g} to {:.3g} lp/mm), {} elements x 2 "
             "orientations, {} shapes, {}\n",
             a.style == "usaf" ? "USAF-1951-style tactile layout" : "MIL-STD-150A standard chart",
             layout.width_mm, layout.height_mm, layout.first_group, layout.last_group,
             usaf_lp_per_mm(layout.first_group, 1),
             usaf_lp_per_mm(layout.last_group, kUsafElementsPerGroup), layout.elements.size() / 2,
             layout.artwork.size(), to_string(layout.polarity));
  fmt::print("  raster {} x {} px at {:g} px/mm; relief {:g} mm on a {:g} mm base, {} triangles\n",
             w, h, ppm, layout.relief_height_mm, layout.base_thickness_mm, mesh.triangles.size());
  return kExitOk;
}

}  // namespace

Command generate_command() {
  return {"generate", "Write the target: layout JSON, SVG, raster, height map and STL relief",
          [](CLI::App& app) -> std::function<int()> {
            auto a = std::make_shared<GenerateArgs>();
            app.add_option("--out,-o", a->out_dir,
                           "Output folder (created if missing); gets layout.json, target.svg, "
                           "target.png, target.tif, height.tif, relief.stl")
                ->required();
            app.add_option("--style", a->style,
                           "usaf: the project's packed layout with fiducials and a reference patch; "
                           "mil-std-150a: the standard USAF-1951 chart (groups in pairs spiralling "
                           "inward, the large square, no fiducials; docs/CHART.md)")
                ->capture_default_str()
                ->check(CLI::IsMember({"usaf", "mil-std-150a"}));
            auto* first = app.add_option("--first-group", a->layout.first_group,
                                         "Coarsest USAF group, -10..12 (group g element e: 2^(g+(e-1)/6) "
                                         "lp/mm); default 0, or -2 for mil-std-150a")
                              ->capture_default_str();
            auto* last = app.add_option("--last-group", a->layout.last_group,
                                        "Finest USAF group, >= --first-group; default 4, or 7 for mil-std-150a")
                             ->capture_default_str();
            auto* field = app.add_option("--field-mm", a->field_mm,
                                         "Field size in mm as W or WxH, each side in [5, 1000] "
                                         "(default 20x20)");
            auto* fw = app.add_option("--field-width-mm", a->layout.field_width_mm, "Field width in mm, [5, 1000]")
                           ->capture_default_str()
                           ->excludes(field);
            auto* fh = app.add_option("--field-height-mm", a->layout.field_height_mm,
                                      "Field height in mm, [5, 1000]")
                           ->capture_default_str()
                           ->excludes(field);
            app.add_option("--px-per-mm", a->px_per_mm,
                           "Raster resolution in pixels per mm, (0, 2000]; image size is "
                           "ceil(field * px/mm)")
                ->capture_default_str();
            app.add_option("--relief-um", a->relief_um,
                           "Relief step in micrometres: bar tops above the ground, (0, 10000]")
                ->capture_default_str();
            app.add_option("--base-mm", a->layout.base_thickness_mm,
                           "Thickness of the STL base plate in mm, (0, 100]")
                ->capture_default_str();
            app.add_option("--polarity", a->polarity, "Raster and SVG colours")
                ->capture_default_str()
                ->check(CLI::IsMember({"dark_bars_on_light", "light_bars_on_dark"}));
            app.add_option("--disc-segments", a->stl.disc_segments,
                           "Sides of the polygon that stands for each fiducial disc in the STL, "
                           "[8, 4096]")
                ->capture_default_str();
            return [a, first, last, field, fw, fh]() {
              a->first_given = first->count() > 0;
              a->last_given = last->count() > 0;
              a->field_given = field->count() > 0 || fw->count() > 0 || fh->count() > 0;
              return run_generate(*a);
            };
          }};
}

}  // namespace tactres::cli
