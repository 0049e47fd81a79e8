// The pixel encoding through the real command line (issue 12): a 16-bit
// PNG with no colour tag holding linear values is measured as linear by
// default; forced to the wrong curve, the output names the likely encoding
// problem; an untagged 16-bit PNG that holds sRGB codes is recognised by its
// reference patch and measured as sRGB, and says so.
#include <sys/wait.h>

#include <cmath>
#include <fstream>

#include <OpenImageIO/imageio.h>
#include <doctest/doctest.h>
#include <nlohmann/json.hpp>

#include "scene_fixtures.h"
#include "tactres/camera/transfer_curve.h"
#include "tactres/targets/layout_json.h"

using namespace tactres;
using namespace tactres::testing;
namespace fs = std::filesystem;

namespace {

// A 16-bit PNG with no colour chunk at all, as plain machine-vision
// software writes it: OpenImageIO adds none when no colour space is set.
void write_untagged_png16(const fs::path& file, const cv::Mat& linear, const TransferCurve& encode_with) {
  std::vector<uint16_t> codes(linear.total());
  for (int y = 0; y < linear.rows; ++y)
    for (int x = 0; x < linear.cols; ++x) {
      const float code = encode_with.to_code(std::clamp(linear.at<float>(y, x), 0.0f, 1.0f));
      codes[size_t(y) * linear.cols + x] = uint16_t(std::lround(code * 65535.0f));
    }
  auto out = OIIO::ImageOutput::create(file.string());
  REQUIRE(out);
  REQUIRE(out->open(file.string(), OIIO::ImageSpec(linear.cols, linear.rows, 1, OIIO::TypeDesc::UINT16)));
  REQUIRE(out->write_image(OIIO::TypeDesc::UINT16, codes.data()));
  REQUIRE(out->close());
}

struct CliResult {
  int exit_code = -1;
  std::string out;
  nlohmann::json json;
};

CliResult measure_cli(const fs::path& image, const fs::path& layout, const fs::path& dir, const std::string& extra) {
  const fs::path json = dir / (image.stem().string() + std::to_string(extra.size()) + ".json");
  const fs::path text = dir / "stdout.txt";
  const std::string cmd = std::string(TACTRES_BINARY) + " measure " + image.string() + " --layout " +
                          layout.string() + " --camera " +
                          (source_dir() / "examples/cameras/wide_angle.cameramodel").string() + " -o " +
                          json.string() + " " + extra + " > " + text.string() + " 2>&1";
  const int status = std::system(cmd.c_str());
  CliResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream t(text);
  r.out.assign(std::istreambuf_iterator<char>(t), std::istreambuf_iterator<char>());
  std::ifstream j(json);
  if (j) r.json = nlohmann::json::parse(j);
  return r;
}

double interpolated(const nlohmann::json& j, const char* orientation) {
  const nlohmann::json& l = j["limits"][orientation];
  return l["interpolated_lp_per_mm"].is_number() ? l["interpolated_lp_per_mm"].get<double>() : 0.0;
}

int count_status(const nlohmann::json& j, const std::string& status) {
  int n = 0;
  for (const auto& e : j["elements"]) n += e["status"] == status;
  return n;
}

}  // namespace

TEST_CASE("encoding: untagged 16-bit linear PNG measured right by default, forced to sRGB, the output says so") {
  TempDir dir("encoding");
  const fs::path layout = dir.path / "layout.json";
  write_layout_file(layout, default_layout());
  ViewPose v;
  v.roll_deg = 4;
  const Scene scene = albedo_scene(v, 1.3, 2);
  const RenderResult render = render_scene(scene, default_layout(), wide_angle_camera());
  const Truth truth = compute_truth(scene, default_layout(), wide_angle_camera());
  const fs::path linear_png = dir.path / "linear.png";
  write_untagged_png16(linear_png, render.image, TransferCurve::linear());

  const CliResult right = measure_cli(linear_png, layout, dir.path, "");
  REQUIRE(right.exit_code == 0);
  CHECK(right.json["input"]["transfer"] == "linear");
  CHECK(right.json["input"]["transfer_reason"] == "16-bit, no colour tag");
  CHECK(right.json["warnings"].empty());
  CHECK(right.out.find("pixels linear (16-bit, no colour tag)") != std::string::npos);
  for (const char* o : {"horizontal_bars", "vertical_bars"}) {
    const Limit& t = std::string(o) == "horizontal_bars" ? truth.horizontal : truth.vertical;
    REQUIRE(t.interpolated_lp_per_mm);
    CHECK(std::abs(interpolated(right.json, o) / *t.interpolated_lp_per_mm - 1) < 0.01);
  }

  const CliResult wrong = measure_cli(linear_png, layout, dir.path, "--transfer srgb");
  REQUIRE(wrong.exit_code == 0);  // measured as told, never refused for it
  CHECK(wrong.json["input"]["transfer"] == "srgb");
  CHECK(wrong.json["transfer_check"]["mismatch"] == true);
  CHECK(wrong.json["transfer_check"]["best"] == "linear");
  REQUIRE(wrong.json["warnings"].size() == 1);
  CHECK(wrong.json["warnings"][0].get<std::string>().find("use --transfer linear") != std::string::npos);
  CHECK(wrong.out.find("warning: the profiles fit as if the file were linear-encoded") != std::string::npos);
  CHECK(count_status(wrong.json, "aliased") == 0);  // the patch shows a global mismatch, not aliasing

  // A power law is accepted on the command line, and named as wrong too.
  const CliResult gamma = measure_cli(linear_png, layout, dir.path, "--transfer gamma:2.2");
  REQUIRE(gamma.exit_code == 0);
  CHECK(gamma.json["input"]["transfer"] == "gamma 2.2");
  CHECK(gamma.json["transfer_check"]["best"] == "linear");
  // A curve tactres does not know is a usage error (exit 3) that lists the accepted ones.
  const CliResult bogus = measure_cli(linear_png, layout, dir.path, "--transfer gamma:x");
  CHECK(bogus.exit_code == 3);
  CHECK(bogus.out.find("use auto, linear, srgb or gamma:G") != std::string::npos);
}

TEST_CASE("encoding: an untagged 16-bit PNG holding sRGB codes is recognised and measured as sRGB") {
  TempDir dir("encoding-srgb");
  const fs::path layout = dir.path / "layout.json";
  write_layout_file(layout, default_layout());
  const Scene scene = albedo_scene({}, 1.3, 2);
  const RenderResult render = render_scene(scene, default_layout(), wide_angle_camera());
  const Truth truth = compute_truth(scene, default_layout(), wide_angle_camera());
  const fs::path srgb_png = dir.path / "srgb_codes.png";
  write_untagged_png16(srgb_png, render.image, TransferCurve::srgb());

  const CliResult r = measure_cli(srgb_png, layout, dir.path, "");
  REQUIRE(r.exit_code == 0);
  CHECK(r.json["input"]["transfer"] == "srgb");
  CHECK(r.json["transfer_check"]["switched"] == true);
  CHECK(r.json["input"]["transfer_reason"].get<std::string>().find("switched") != std::string::npos);
  REQUIRE(r.json["warnings"].size() == 1);
  CHECK(r.json["warnings"][0].get<std::string>().find("--transfer srgb") != std::string::npos);
  for (const char* o : {"horizontal_bars", "vertical_bars"}) {
    const Limit& t = std::string(o) == "horizontal_bars" ? truth.horizontal : truth.vertical;
    REQUIRE(t.interpolated_lp_per_mm);
    CHECK(std::abs(interpolated(r.json, o) / *t.interpolated_lp_per_mm - 1) < 0.01);
  }
}
