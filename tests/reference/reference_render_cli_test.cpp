// The reference_render CLI, run as a person would: a case file in, an image
// and a truth file out.
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <doctest/doctest.h>

#include "e2e_support.h"

using namespace reference;
using namespace reference::e2e;

TEST_CASE("renderer: reference_render writes the image and its truth from a case file") {
  TempDir dir("cli");
  const nlohmann::json case_json = {
      {"layout", default_layout_path().string()},
      {"camera", {{"pinhole", {{"size_px", {320, 240}}, {"fx_px", 140}, {"fy_px", 140}, {"cx_px", 159.5},
                               {"cy_px", 119.5}}}}},
      {"pose", {{"distance_mm", 26}, {"roll_deg", 10}, {"mirrored", true}}},
      {"scene", {{"mode", "albedo"}, {"sigma_mm", 0.2}, {"snr_db", 40}, {"seed", 3}}},
      {"output", {{"image", "small.png"}, {"format", "png8"}}}};
  std::ofstream(dir.path / "case.json") << case_json.dump(2);
  const std::string cmd = std::string(REFERENCE_RENDER_BINARY) + " " + (dir.path / "case.json").string() +
                          " > " + (dir.path / "log.txt").string() + " 2>&1";
  REQUIRE(std::system(cmd.c_str()) == 0);
  CHECK(fs::file_size(dir.path / "small.png") > 1000);
  std::ifstream in(dir.path / "small.png.truth.json");
  const nlohmann::json truth = nlohmann::json::parse(in);
  CHECK(truth["schema"] == "tactres.reference_truth/1");
  CHECK(truth["sigma_mm"].get<double>() == 0.2);
  CHECK(truth["pose"]["mirrored"].get<bool>());
  CHECK(truth["elements"].size() == default_layout().elements.size());
  CHECK(truth["limits"]["horizontal_bars"]["interpolated_lp_per_mm"].get<double>() ==
        doctest::Approx(interpolated_limit_lp_per_mm(0.2, 0.1)));

  // An unknown key is refused with exit 3.
  nlohmann::json bad = case_json;
  bad["scene"]["sigma_px"] = 1;
  std::ofstream(dir.path / "bad.json") << bad.dump(2);
  const int status = std::system((std::string(REFERENCE_RENDER_BINARY) + " " + (dir.path / "bad.json").string() +
                                  " > /dev/null 2>&1").c_str());
  CHECK(WEXITSTATUS(status) == 3);
}
