// reference_render CASE.json [--print-truth]
// Renders one capture with the independent reference renderer and writes
// the image and its truth JSON (see case_file.cpp for the case format).
#include <cstdio>
#include <cstring>
#include <exception>

#include "reference_renderer.h"

int main(int argc, char** argv) {
  if (argc < 2 || std::strcmp(argv[1], "--help") == 0 || std::strcmp(argv[1], "-h") == 0) {
    std::printf("usage: reference_render CASE.json\n"
                "Renders a capture of a tactres layout with the independent reference renderer\n"
                "(Gaussian blur sigma_mm in the target plane, analytic; point sampling; mrcal\n"
                "projection) and writes the image and a truth JSON. See tests/reference/README.md.\n");
    return argc < 2 ? 3 : 0;
  }
  try {
    const reference::RenderCase c = reference::read_case(argv[1]);
    const reference::Truth t = reference::run_case(c);
    std::printf("%s: sigma %.4f mm; true limit H %.4f lp/mm (G%dE%d), V %.4f lp/mm (G%dE%d)\n",
                c.image_path.c_str(), t.sigma_mm, t.horizontal_bars.interpolated_lp_per_mm,
                t.horizontal_bars.group, t.horizontal_bars.element, t.vertical_bars.interpolated_lp_per_mm,
                t.vertical_bars.group, t.vertical_bars.element);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "reference_render: %s\n", e.what());
    return 3;
  }
}
