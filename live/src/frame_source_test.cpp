#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>

#include <opencv2/videoio.hpp>

#include "scene_fixtures.h"
#include "tactres/live/frame_source.h"

using namespace tactres;
using tactres::testing::TempDir;
namespace fs = std::filesystem;

namespace {
void write_grey(const fs::path& p, float level) {
  write_image(p, cv::Mat(24, 32, CV_16U, cv::Scalar(level * 65535)));
}
}  // namespace

TEST_CASE("frame source: a folder is read in name order, a bad file is reported and skipped") {
  TempDir dir("frames");
  write_grey(dir.path / "b.png", 0.5f);
  write_grey(dir.path / "a.png", 0.25f);
  std::ofstream(dir.path / "c.png") << "not a png";
  std::ofstream(dir.path / "notes.txt") << "ignored";
  write_grey(dir.path / "d.png", 0.75f);
  auto src = open_frame_source(dir.path.string(), {});
  CHECK(src->describe().find("4 image(s)") != std::string::npos);
  std::vector<std::string> names;
  std::vector<double> levels;
  while (auto f = src->next()) {
    names.push_back(f->name);
    levels.push_back(f->image ? f->image->luminance.at<float>(0, 0) : -1.0);
    if (f->name == "c.png") CHECK(f->problem.find("c.png") != std::string::npos);
  }
  CHECK(names == std::vector<std::string>{"a.png", "b.png", "c.png", "d.png"});
  CHECK(levels[0] == doctest::Approx(0.25).epsilon(1e-3));  // 16-bit untagged: linear
  CHECK(levels[2] == -1.0);
  CHECK(levels[3] == doctest::Approx(0.75).epsilon(1e-3));
}

TEST_CASE("frame source: a glob picks its files; a missing source says what to give") {
  TempDir dir("glob");
  write_grey(dir.path / "x1.png", 0.1f);
  write_grey(dir.path / "x2.png", 0.2f);
  write_grey(dir.path / "y.png", 0.3f);
  auto src = open_frame_source((dir.path / "x*.png").string(), {});
  int n = 0;
  while (src->next()) ++n;
  CHECK(n == 2);
  CHECK_THROWS_WITH_AS(open_frame_source((dir.path / "nothing").string(), {}), doctest::Contains("no such file"),
                       std::runtime_error);
  CHECK_THROWS_WITH_AS(open_frame_source((dir.path / "z*.png").string(), {}), doctest::Contains("no file matches"),
                       std::runtime_error);
  fs::create_directories(dir.path / "empty");
  CHECK_THROWS_WITH_AS(open_frame_source((dir.path / "empty").string(), {}), doctest::Contains("holds no image"),
                       std::runtime_error);
}

TEST_CASE("frame source: a lossless video comes back frame by frame, 8-bit frames decoded as sRGB") {
  TempDir dir("video");
  const fs::path path = dir.path / "seq.avi";
  cv::VideoWriter writer(path.string(), cv::VideoWriter::fourcc('F', 'F', 'V', '1'), 10, cv::Size(64, 48), false);
  if (!writer.isOpened()) {
    MESSAGE("this OpenCV build has no FFV1 encoder: the video case is skipped");
    return;
  }
  for (int i = 0; i < 5; ++i) writer.write(cv::Mat(48, 64, CV_8U, cv::Scalar(40 * i + 20)));
  writer.release();
  auto src = open_frame_source(path.string(), {});
  int n = 0;
  while (auto f = src->next()) {
    REQUIRE(f->image);
    const double code = (40.0 * n + 20) / 255;
    const double srgb = code <= 0.04045 ? code / 12.92 : std::pow((code + 0.055) / 1.055, 2.4);
    CHECK(f->image->luminance.at<float>(10, 10) == doctest::Approx(srgb).epsilon(1e-3));
    ++n;
  }
  CHECK(n == 5);
}
