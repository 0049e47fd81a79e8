// End to end: `tactres measure --chart usaf1951` on the command line, for
// captures it cannot measure (docs/CHART.md; helpers in
// measure_chart_support.h): no chart at all, and a chart where nothing is
// resolved, are both exit 2 with a message saying which.
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>

#include <sys/wait.h>

#include <opencv2/core.hpp>

#include <doctest/doctest.h>
#include <nlohmann/json.hpp>

#include "measure_chart_support.h"

using namespace tactres;
using namespace tactres::testing;
using namespace tactres::chart_e2e;

namespace {
// `tactres measure IMAGE --chart usaf1951 -o JSON`: exit code and stderr.
int run_chart_cli(const std::filesystem::path& image, const std::filesystem::path& json, std::string& err) {
  const std::filesystem::path err_file = json.string() + ".err";
  const std::string cmd = std::string(TACTRES_BINARY) + " measure " + image.string() + " --chart usaf1951 -o " +
                          json.string() + " 2> " + err_file.string() + " > /dev/null";
  const int status = std::system(cmd.c_str());
  std::ifstream f(err_file);
  err.assign(std::istreambuf_iterator<char>(f), {});
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}
}  // namespace

TEST_CASE("chart CLI: a photograph with no chart is exit 2 with a clear message") {
  TempDir dir("chart-cli");
  cv::Mat img(480, 640, CV_32F);
  cv::randn(img, 0.5, 0.02);
  // Soft blobs and a gradient: structure, but no three-bar pattern.
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x)
      img.at<float>(y, x) += 0.2f * std::sin(x / 37.0) * std::cos(y / 23.0) + 0.0003f * x;
  const auto file = dir.path / "nochart.tif";
  write_image(file, img);
  std::string err;
  CHECK(run_chart_cli(file, dir.path / "nochart.json", err) == 2);
  CHECK(err.find("no USAF-1951 chart found") != std::string::npos);
  std::ifstream j(dir.path / "nochart.json");
  const nlohmann::json m = nlohmann::json::parse(j);
  CHECK(m["usable"] == false);
  CHECK(m["chart"]["found"] == false);
}

TEST_CASE("chart CLI: a chart so blurred that nothing resolves is exit 2, the coarsest element is unresolved") {
  TempDir dir("chart-cli");
  ChartScene c;
  c.view = view_at(36);
  c.blur_sigma_px = 12.5;  // m of G0E1 (18 px per bar) ~0.09
  const Scene s = scene_of(c);
  const RenderResult r = render_scene(s, chart(), pinhole_camera());
  const auto file = dir.path / "blurred.tif";
  write_image(file, r.image, r.bits);
  const Truth truth = compute_truth(s, chart(), pinhole_camera());
  CHECK_FALSE(visible_truth_limits(truth, Criterion{}).horizontal.any_resolved);
  std::string err;
  CHECK(run_chart_cli(file, dir.path / "blurred.json", err) == 2);
  CAPTURE(err);
  std::ifstream j(dir.path / "blurred.json");
  const nlohmann::json m = nlohmann::json::parse(j);
  CHECK(m["usable"] == false);
  if (m["chart"]["found"] == true) {
    REQUIRE(!m["elements"].empty());
    CHECK(m["elements"][0]["resolved"] == false);
    CHECK(err.find("nothing on the chart is resolved") != std::string::npos);
    MESSAGE("blurred chart: coarsest element found G" << m["elements"][0]["group"] << "E" << m["elements"][0]["element"]
                                                      << ", m " << m["elements"][0]["m"]);
  } else {
    CHECK(err.find("no USAF-1951 chart found") != std::string::npos);
    MESSAGE("blurred chart: not found at all");
  }
}
