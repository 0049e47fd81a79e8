#pragma once
// Shared by the hard_cases_*_test.cpp suites (issue 7, docs/STABILITY.md):
// the usual capture of the hard cases, its files on disk and on the command
// line, and the comparisons of their limits. The checks every stability
// case makes are in stability_support.h.

#include <filesystem>
#include <string>
#include <vector>

#include "stability_support.h"

namespace tactres::stability::hard_cases {

// The project's usual capture: the wide-angle example camera 26 mm from a
// printed target, Gaussian blur, exact coverage (float) unless a sensor is
// added.
Scene scene_with(ViewPose v = {}, double blur_sigma_px = 1.2);

LoadedImage as_loaded(const RenderResult& r);

// A temporary folder holding the default layout's file and the captures.
struct Files {
  testing::TempDir dir{"stability"};
  std::filesystem::path layout = dir.path / "layout.json";
  Files() { write_layout_file(layout, testing::default_layout()); }
  std::filesystem::path write(const std::string& name, const cv::Mat& image, int bits = 0) const {
    const std::filesystem::path p = dir.path / name;
    write_image(p, image, bits);
    return p;
  }
};

// `tactres measure` with the wide-angle example model (the camera of most
// cases here), unless `extra` names another --camera or says "no-camera".
CliRun cli(const Files& f, const std::filesystem::path& image, int expected, std::vector<std::string> extra = {});

bool any_resolved(const Measurement& m);

// The limits of two measurements of one scene agree: the same discrete
// limit, or interpolated limits within `z` combined standard errors.
void check_limits_agree(const Limit& a, const Limit& b, double z = 3.0);

// Paints a disc of `radius_px` around the image of a fiducial with `level`.
void occlude_fiducial(cv::Mat& image, const Scene& s, const CameraModel& cam, const std::string& id, float level);

// The measurement of scene_with() through the wide-angle camera, made once:
// the baseline that other cases compare their limits with.
const Measured& reference_measurement();

}  // namespace tactres::stability::hard_cases
