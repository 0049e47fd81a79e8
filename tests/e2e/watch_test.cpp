// `tactres watch` end to end (issue 16, docs/LIVE.md): a simulated
// sequence whose defocus sweeps through the best focus, written as an image
// folder and as a lossless video; the watch CLI must name the frame of best
// focus that the truth files name, and its per-frame limits must agree with
// `tactres measure` on the same files. A sequence in which the target drops
// out for a few frames (and one file is truncated) must go on and recover.
#include <doctest/doctest.h>

#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "scene_fixtures.h"
#include "tactres/targets/layout_json.h"

using namespace tactres;
using namespace tactres::testing;
namespace fs = std::filesystem;

namespace {

constexpr int kFrames = 9;
constexpr int kBestFrame = 6;  // the sweep's sharpest frame (not the middle one)

// Frame i: Gaussian blur falling to its least at kBestFrame, the target
// drifting (roll and offset) as on a jig, its own sensor noise.
Scene sweep_scene(int i) {
  ViewPose v;
  v.roll_deg = 3 + 0.2 * i;
  v.offset_mm = {0.03 * i, -0.02 * i};
  Scene s = albedo_scene(v, 1.2 + 0.5 * std::abs(i - kBestFrame), 2);
  SensorOptions sensor = sensor_40db(100 + i);
  sensor.bit_depth = 10;
  s.effects.emplace_back(sensor);
  return s;
}

// The value the best focus is ranked by: the mean of the two reported
// limits (interpolated where there is one), as `tactres watch` ranks frames.
double limit_score(const Limit& h, const Limit& v) {
  auto value = [](const Limit& l) { return l.any_resolved ? l.interpolated_lp_per_mm.value_or(l.lp_per_mm) : 0.0; };
  return 0.5 * (value(h) + value(v));
}

struct Sequence {
  TempDir dir{"watch"};
  fs::path frames, layout, camera;
  std::vector<Truth> truths;
  std::vector<cv::Mat> images;  // as rendered, for the video
  int bits = 0;
};

const Sequence& sweep() {
  static Sequence* s = [] {
    auto* q = new Sequence;
    q->frames = q->dir.path / "frames";
    fs::create_directories(q->frames);
    q->layout = q->dir.path / "layout.json";
    write_layout_file(q->layout, default_layout());
    q->camera = source_dir() / "examples/cameras/wide_angle.cameramodel";
    for (int i = 0; i < kFrames; ++i) {
      const Scene scene = sweep_scene(i);
      const RenderResult r = render_scene(scene, default_layout(), wide_angle_camera());
      write_image(q->frames / fmt::format("frame_{:02d}.png", i), r.image, r.bits);
      q->truths.push_back(compute_truth(scene, default_layout(), wide_angle_camera()));
      q->images.push_back(r.image);
      q->bits = r.bits;
    }
    return q;
  }();
  return *s;
}

struct Run {
  int status = -1;
  std::string out;
};

Run run_cli(const std::string& args, const fs::path& dir) {
  const fs::path out = dir / "stdout.txt";
  const std::string cmd = std::string(TACTRES_BINARY) + " " + args + " > " + out.string() + " 2> /dev/null";
  Run r;
  const int st = std::system(cmd.c_str());
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  std::ifstream in(out);
  r.out.assign(std::istreambuf_iterator<char>(in), {});
  return r;
}

// The watch CSV as rows of named cells (the cells before `problem`, the
// last column, hold no commas).
std::vector<std::map<std::string, std::string>> read_csv(const fs::path& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> names;
  std::stringstream hs(line);
  for (std::string c; std::getline(hs, c, ',');) names.push_back(c);
  std::vector<std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    std::map<std::string, std::string> row;
    std::stringstream ls(line);
    std::string c;
    for (size_t k = 0; k < names.size() && std::getline(ls, c, ','); ++k) row[names[k]] = c;
    rows.push_back(row);
  }
  return rows;
}

int truth_best_frame(const Sequence& s) {
  int best = 0;
  for (int i = 1; i < kFrames; ++i)
    if (limit_score(s.truths[i].horizontal, s.truths[i].vertical) >
        limit_score(s.truths[best].horizontal, s.truths[best].vertical))
      best = i;
  return best;
}

// "best frame: 6 (frame_06.png): ..." -> 6
int printed_best_frame(const std::string& out) {
  const size_t at = out.find("best frame: ");
  REQUIRE_MESSAGE(at != std::string::npos, out);
  return std::atoi(out.c_str() + at + 12);
}

}  // namespace

TEST_CASE("watch: an image folder through focus names the truth's best frame and agrees with measure") {
  const Sequence& s = sweep();
  REQUIRE(truth_best_frame(s) == kBestFrame);
  TempDir out("watch-out");
  const fs::path csv = out.path / "watch.csv";
  const std::string common = " --layout " + s.layout.string() + " --camera " + s.camera.string();
  const Run w = run_cli("watch " + s.frames.string() + common + " --csv " + csv.string(), out.path);
  REQUIRE_MESSAGE(w.status == 0, w.out);
  CHECK(printed_best_frame(w.out) == kBestFrame);
  const auto rows = read_csv(csv);
  REQUIRE(rows.size() == size_t(kFrames));

  // The same files through `tactres measure` (the preset watch uses).
  const Run m = run_cli("measure " + (s.frames / "*.png").string() + common + " --preset fast --out-dir " +
                            (out.path / "m").string(),
                        out.path);
  REQUIRE(m.status == 0);
  int tracked = 0;
  for (int i = 0; i < kFrames; ++i) {
    CAPTURE(i);
    const auto& row = rows[i];
    REQUIRE(row.at("status") == "ok");
    tracked += row.at("tracked") == "1";
    std::ifstream js(out.path / "m" / fmt::format("frame_{:02d}.json", i));
    const nlohmann::json j = nlohmann::json::parse(js);
    for (const char* o : {"h", "v"}) {
      CAPTURE(o);
      const nlohmann::json& l = j["limits"][std::string(o) == "h" ? "horizontal_bars" : "vertical_bars"];
      CHECK(std::stoi(row.at(std::string(o) + "_group")) == l["group"].get<int>());
      CHECK(std::stoi(row.at(std::string(o) + "_element")) == l["element"].get<int>());
      const std::string interp = row.at(std::string(o) + "_interpolated_lp_per_mm");
      REQUIRE(interp.empty() == l["interpolated_lp_per_mm"].is_null());
      if (interp.empty()) continue;
      // Tracked frames carry the reference patch and start the pose from
      // the frame before: the same measurand within the two uncertainties.
      const double a = std::stod(interp), b = l["interpolated_lp_per_mm"].get<double>();
      const double sa = std::stod(row.at(std::string(o) + "_uncertainty_lp_per_mm"));
      const double sb = l["uncertainty_lp_per_mm"].get<double>();
      CHECK(std::abs(a - b) <= std::hypot(sa, sb) + 1e-6);
    }
  }
  CHECK(tracked == kFrames - 1);  // every frame after the first found the target where it was
}

TEST_CASE("watch: a lossless video of the sweep names the same best frame") {
  const Sequence& s = sweep();
  TempDir out("watch-video");
  const fs::path video = out.path / "sweep.avi";
  // 8-bit frames, sRGB-encoded as a camera's video would be; FFV1 is lossless.
  cv::VideoWriter writer(video.string(), cv::VideoWriter::fourcc('F', 'F', 'V', '1'), 10,
                         cv::Size(s.images[0].cols, s.images[0].rows), false);
  if (!writer.isOpened()) {
    MESSAGE("this OpenCV build has no FFV1 encoder: the video case is skipped");
    return;
  }
  const double full = (1 << s.bits) - 1;
  for (const cv::Mat& img : s.images) {
    cv::Mat lin, code8;
    img.convertTo(lin, CV_32F, 1 / full);
    lin.forEach<float>([](float& v, const int*) {
      v = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1 / 2.4f) - 0.055f;
    });
    lin.convertTo(code8, CV_8U, 255.0);
    writer.write(code8);
  }
  writer.release();
  const fs::path csv = out.path / "video.csv";
  const Run w = run_cli("watch " + video.string() + " --layout " + s.layout.string() + " --camera " +
                            s.camera.string() + " --csv " + csv.string(),
                        out.path);
  REQUIRE_MESSAGE(w.status == 0, w.out);
  CHECK(printed_best_frame(w.out) == kBestFrame);
  const auto rows = read_csv(csv);
  REQUIRE(rows.size() == size_t(kFrames));
  for (const auto& row : rows) CHECK(row.at("status") == "ok");
}

TEST_CASE("watch: the target drops out for a few frames and a file is truncated: the sequence goes on and recovers") {
  const Sequence& s = sweep();
  TempDir out("watch-dropout");
  const fs::path frames = out.path / "frames";
  fs::create_directories(frames);
  // Frames 0-2 and 6-8 of the sweep; 3 and 4 show no target (the flat ground
  // with noise); 5 is a truncated PNG.
  for (int i : {0, 1, 2, 6, 7, 8})
    fs::copy_file(s.frames / fmt::format("frame_{:02d}.png", i), frames / fmt::format("frame_{:02d}.png", i));
  for (int i : {3, 4}) {
    cv::Mat ground(s.images[0].rows, s.images[0].cols, CV_16U);
    cv::randn(ground, cv::Scalar(0.8 * 65535), cv::Scalar(300));
    write_image(frames / fmt::format("frame_{:02d}.png", i), ground);
  }
  {
    std::ifstream src(s.frames / "frame_05.png", std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(src)), {});
    std::ofstream(frames / "frame_05.png", std::ios::binary) << bytes.substr(0, bytes.size() / 3);
  }
  const fs::path csv = out.path / "dropout.csv";
  const Run w = run_cli("watch " + frames.string() + " --layout " + s.layout.string() + " --camera " +
                            s.camera.string() + " --csv " + csv.string(),
                        out.path);
  REQUIRE_MESSAGE(w.status == 0, w.out);
  const auto rows = read_csv(csv);
  REQUIRE(rows.size() == size_t(kFrames));
  for (int i = 0; i < kFrames; ++i) {
    CAPTURE(i);
    const bool gone = i >= 3 && i <= 5;
    CHECK(rows[i].at("status") == (gone ? "unusable" : "ok"));
    if (gone) CHECK(rows[i].at("h_lp_per_mm").empty());
  }
  CHECK(rows[6].at("tracked") == "0");  // found again by a full search
  CHECK(rows[7].at("tracked") == "1");  // and tracked from there on
  CHECK(printed_best_frame(w.out) == kBestFrame);
  CHECK(w.out.find("9 frame(s), 6 measured") != std::string::npos);
}
