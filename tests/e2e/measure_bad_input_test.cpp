// Bad input through the real command line: the documented exit code, a
// message that names the problem, and no partial output.
#include <sys/wait.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <set>

#include <doctest/doctest.h>
#include <opencv2/imgcodecs.hpp>
#include <nlohmann/json.hpp>

#include "scene_fixtures.h"
#include "tactres/util/atomic_file.h"
#include "tactres/targets/layout_json.h"

using namespace tactres;
using namespace tactres::testing;
namespace fs = std::filesystem;

namespace {

struct Run {
  int exit_code;
  std::string err;
};

Run run_measure(const fs::path& dir, const std::string& args) {
  const fs::path err = dir / "stderr.txt";
  const std::string cmd = std::string(TACTRES_BINARY) + " measure " + args + " 2> " + err.string() + " > /dev/null";
  const int status = std::system(cmd.c_str());
  std::ifstream f(err);
  std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, text};
}

// Only the listed files may exist in `dir` (no temporaries, no partial outputs).
void check_only(const fs::path& dir, std::set<std::string> allowed) {
  for (const auto& e : fs::directory_iterator(dir)) {
    CAPTURE(e.path().string());
    CHECK(allowed.count(e.path().filename().string()) == 1);
  }
}

struct Fixture {
  TempDir dir{"badinput"};
  fs::path layout = dir.path / "layout.json";
  fs::path good;
  Fixture() {
    write_layout_file(layout, default_layout());
    good = render_to_file(albedo_scene({}, 1.2), pinhole_camera(), dir.path, "good").file;
  }
  std::string common(const fs::path& image) const {
    return image.string() + " --layout " + layout.string() + " -o " + (dir.path / "out.json").string() +
           " --csv " + (dir.path / "out.csv").string() + " --overlay " + (dir.path / "out.png").string();
  }
};

}  // namespace

TEST_CASE("measure: a good capture is within spec (exit 0) and below a --require limit (exit 1)") {
  Fixture f;
  Run r = run_measure(f.dir.path, f.common(f.good) + " --camera " + (source_dir() / "examples/cameras/pinhole.cameramodel").string());
  CHECK(r.exit_code == 0);
  CHECK(fs::exists(f.dir.path / "out.json"));
  CHECK(fs::exists(f.dir.path / "out.csv"));
  CHECK(fs::exists(f.dir.path / "out.png"));
  r = run_measure(f.dir.path, f.common(f.good) + " --require-h 40");
  CHECK(r.exit_code == 1);
  // JUnit is an output of its own: a CI gate needs nothing else.
  fs::remove(f.dir.path / "junit.xml");
  r = run_measure(f.dir.path, f.good.string() + " --layout " + f.layout.string() + " --require-h 40 --junit " +
                                  (f.dir.path / "junit.xml").string());
  CHECK(r.exit_code == 1);
  CHECK(fs::exists(f.dir.path / "junit.xml"));
}

TEST_CASE("measure: a spec that is not a frequency is refused (NaN would pass every capture)") {
  Fixture f;
  for (const std::string spec : {"nan", "-1", "0", "inf", "5x"}) {
    CAPTURE(spec);
    const Run r = run_measure(f.dir.path, f.common(f.good) + " --require-h " + spec);
    CHECK(r.exit_code == 3);
    CHECK(r.err.find("--require-h") != std::string::npos);
  }
  check_only(f.dir.path, {"layout.json", "good.tif", "stderr.txt"});
}

TEST_CASE("measure: a capture's outputs are written all or none, into folders made for them") {
  Fixture f;
  // The CSV cannot be written (its folder is a file): no JSON or overlay either.
  std::ofstream(f.dir.path / "a_file") << "x";
  const fs::path sub = f.dir.path / "new" / "folder";
  Run r = run_measure(f.dir.path, f.good.string() + " --layout " + f.layout.string() + " -o " +
                                      (sub / "m.json").string() + " --csv " + (f.dir.path / "a_file" / "m.csv").string() +
                                      " --overlay " + (sub / "m.png").string());
  CHECK(r.exit_code == 3);
  CHECK(r.err.find("m.csv") != std::string::npos);
  CHECK_FALSE(fs::exists(sub / "m.json"));
  CHECK_FALSE(fs::exists(sub / "m.png"));
  // With writable paths, the missing folders are made.
  r = run_measure(f.dir.path, f.good.string() + " --layout " + f.layout.string() + " -o " + (sub / "m.json").string() +
                                  " --overlay " + (sub / "m.png").string());
  CHECK(r.exit_code == 0);
  CHECK(fs::exists(sub / "m.json"));
  CHECK(fs::exists(sub / "m.png"));
  check_only(sub, {"m.json", "m.png"});
  // A failed set leaves the earlier results as they were.
  fs::create_directories(sub / "occupied.png" / "x");  // the overlay's rename will fail
  r = run_measure(f.dir.path, f.good.string() + " --layout " + f.layout.string() + " -o " + (sub / "m.json").string() +
                                  " --overlay " + (sub / "occupied.png").string());
  CHECK(r.exit_code == 3);
  CHECK(fs::exists(sub / "m.json"));
  CHECK(fs::exists(sub / "m.png"));
}

TEST_CASE("measure: outputs that would overwrite each other are refused before anything is measured") {
  Fixture f;
  Run r = run_measure(f.dir.path, f.good.string() + " --layout " + f.layout.string() + " -o " +
                                      (f.dir.path / "same.out").string() + " --csv " + (f.dir.path / "same.out").string());
  CHECK(r.exit_code == 3);
  CHECK(r.err.find("two outputs go to") != std::string::npos);
  // The overlay over its own capture would destroy it.
  const std::string capture_bytes = read_file(f.good);
  r = run_measure(f.dir.path, f.good.string() + " --layout " + f.layout.string() + " -o " +
                                  (f.dir.path / "m.json").string() + " --overlay " + f.good.string());
  CHECK(r.exit_code == 3);
  CHECK(r.err.find("is also an input") != std::string::npos);
  CHECK(read_file(f.good) == capture_bytes);
  CHECK_FALSE(fs::exists(f.dir.path / "m.json"));
  // Two captures with one stem would write one <stem>.json.
  fs::create_directories(f.dir.path / "a");
  fs::create_directories(f.dir.path / "b");
  fs::copy_file(f.good, f.dir.path / "a" / "x.tif");
  fs::copy_file(f.good, f.dir.path / "b" / "x.tif");
  r = run_measure(f.dir.path, (f.dir.path / "a" / "x.tif").string() + " " + (f.dir.path / "b" / "x.tif").string() +
                                  " --layout " + f.layout.string() + " --out-dir " + (f.dir.path / "out").string());
  CHECK(r.exit_code == 3);
  CHECK(r.err.find("would both write x.json") != std::string::npos);
  CHECK_FALSE(fs::exists(f.dir.path / "out" / "x.json"));
  // --junit's folder is made before measuring.
  r = run_measure(f.dir.path, f.good.string() + " --layout " + f.layout.string() + " --junit " +
                                  (f.dir.path / "ci" / "j.xml").string());
  CHECK(r.exit_code == 0);
  CHECK(fs::exists(f.dir.path / "ci" / "j.xml"));
}

TEST_CASE("measure: truncated and unreadable images") {
  Fixture f;
  const fs::path truncated = f.dir.path / "truncated.png";
  {
    std::ifstream in(f.good, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream out(truncated, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
  }
  Run r = run_measure(f.dir.path, f.common(truncated));
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("truncated") != std::string::npos);
  check_only(f.dir.path, {"layout.json", "good.tif", "truncated.png", "stderr.txt", "out.json"});
  const nlohmann::json j = nlohmann::json::parse(read_file(f.dir.path / "out.json"));
  CHECK(j["usable"] == false);

  r = run_measure(f.dir.path, f.common(f.dir.path / "missing.png"));
  CHECK(r.exit_code == 3);
  CHECK(r.err.find("missing.png") != std::string::npos);
}

TEST_CASE("measure: no target, saturated, all-NaN, wrong layout, wrong camera size") {
  Fixture f;
  // No target: a smooth gradient.
  cv::Mat blank(720, 1280, CV_32F);
  for (int y = 0; y < blank.rows; ++y)
    for (int x = 0; x < blank.cols; ++x) blank.at<float>(y, x) = 0.3f + 0.2f * x / blank.cols;
  write_image(f.dir.path / "blank.tif", blank);
  Run r = run_measure(f.dir.path, f.common(f.dir.path / "blank.tif"));
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("no target found") != std::string::npos);

  // Saturated: every pixel at the top of the range.
  cv::Mat white(720, 1280, CV_16U, cv::Scalar(65535));
  write_image(f.dir.path / "white.png", white);
  r = run_measure(f.dir.path, f.common(f.dir.path / "white.png"));
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("saturated") != std::string::npos);

  // All NaN, as EXR.
  cv::Mat nan(64, 64, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  write_image(f.dir.path / "nan.exr", nan);
  r = run_measure(f.dir.path, f.common(f.dir.path / "nan.exr"));
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("no finite pixel") != std::string::npos);

  // NaN over the left two thirds (masked): the fiducials there are gone,
  // and the message says the pixels were masked.
  cv::Mat masked = cv::imread(f.good.string(), cv::IMREAD_UNCHANGED);
  REQUIRE(masked.type() == CV_32F);
  masked.colRange(0, masked.cols * 2 / 3).setTo(std::numeric_limits<float>::quiet_NaN());
  write_image(f.dir.path / "masked.tif", masked);
  r = run_measure(f.dir.path, f.common(f.dir.path / "masked.tif"));
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("NaN/Inf and were masked") != std::string::npos);

  // The layout of another target: same fiducials, different elements.
  LayoutOptions other;
  other.first_group = 1;
  other.last_group = 5;
  const fs::path other_layout = f.dir.path / "other.json";
  write_layout_file(other_layout, make_layout(other));
  r = run_measure(f.dir.path, f.good.string() + " --layout " + other_layout.string() + " -o " +
                                  (f.dir.path / "o.json").string());
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("layout") != std::string::npos);

  // A camera model for another imager size.
  const fs::path small_cam = f.dir.path / "small.cameramodel";
  CameraModel::pinhole(500, 500, 320, 240, 640, 480).save(small_cam);
  r = run_measure(f.dir.path, f.common(f.good) + " --camera " + small_cam.string());
  CHECK(r.exit_code == 3);
  CHECK(r.err.find("640x480") != std::string::npos);
  CHECK_FALSE(fs::exists(f.dir.path / "out.csv"));
}

TEST_CASE("measure batch: one bad file never stops the others, the exit code is the worst") {
  Fixture f;
  const fs::path bad = f.dir.path / "bad.png";
  std::ofstream(bad) << "not an image";
  const fs::path out = f.dir.path / "batch";
  Run r = run_measure(f.dir.path, f.good.string() + " " + bad.string() + " --layout " + f.layout.string() +
                                      " --out-dir " + out.string() + " --junit " + (f.dir.path / "junit.xml").string());
  CHECK(r.exit_code == 2);
  CHECK(fs::exists(out / "good.json"));
  CHECK(fs::exists(out / "good.csv"));
  CHECK(fs::exists(out / "bad.json"));
  const std::string junit = read_file(f.dir.path / "junit.xml");
  CHECK(junit.find("tests=\"2\"") != std::string::npos);
  CHECK(junit.find("errors=\"1\"") != std::string::npos);
  // A missing file (exit 3) gets its JSON too, saying why, and the batch's
  // last line counts every outcome.
  const std::string cmd = std::string(TACTRES_BINARY) + " measure " + f.good.string() + " " + bad.string() + " " +
                          (f.dir.path / "missing.png").string() + " --layout " + f.layout.string() + " --out-dir " +
                          out.string() + " > " + (f.dir.path / "stdout.txt").string() + " 2> /dev/null";
  const int status = std::system(cmd.c_str());
  CHECK((WIFEXITED(status) ? WEXITSTATUS(status) : -1) == 3);
  const nlohmann::json missing = nlohmann::json::parse(read_file(out / "missing.json"));
  CHECK(missing["usable"] == false);
  CHECK(missing["problem"].get<std::string>().find("missing.png") != std::string::npos);
  CHECK(read_file(f.dir.path / "stdout.txt").find("3 capture(s): 1 measured (0 below spec), 1 unusable, 1 error(s); exit 3") !=
        std::string::npos);
}
