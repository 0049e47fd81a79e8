#include "tactres/live/frame_source.h"

#include <glob.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <filesystem>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>
#include <opencv2/videoio.hpp>

namespace tactres {

namespace fs = std::filesystem;

void CameraSettings::validate() const {
  if (width_px < 16 || width_px > 16384 || height_px < 16 || height_px > 16384)
    throw std::invalid_argument(fmt::format("--size {}x{}: width and height must be in [16, 16384] px", width_px,
                                            height_px));
  if (!(fps > 0 && fps <= 1000)) throw std::invalid_argument(fmt::format("--fps {}: must be in (0, 1000]", fps));
  if (fourcc.size() != 4) throw std::invalid_argument("--fourcc '" + fourcc + "': must be 4 characters, e.g. MJPG");
}

bool is_image_file_name(const std::string& name) {
  static const std::array<const char*, 9> kExtensions = {".png", ".tif", ".tiff", ".jpg", ".jpeg",
                                                         ".exr", ".pgm", ".ppm", ".bmp"};
  std::string ext = fs::path(name).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return std::find(kExtensions.begin(), kExtensions.end(), ext) != kExtensions.end();
}

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Image files in name order, each decoded when it is asked for.
class FileSequence final : public FrameSource {
 public:
  FileSequence(std::vector<fs::path> files, const LoadOptions& load, std::string what)
      : files_(std::move(files)), load_(load), what_(std::move(what)) {}

  std::optional<Frame> next() override {
    if (next_ >= files_.size()) return std::nullopt;
    const fs::path& path = files_[next_];
    Frame f;
    f.index = long(next_++);
    f.name = path.filename().string();
    f.time_s = seconds_since(t0_);
    try {
      f.image = load_image(path, load_);
    } catch (const std::exception& e) {  // unreadable, truncated, NaN: the sequence goes on
      f.problem = e.what();
    }
    return f;
  }

  std::string describe() const override { return fmt::format("{} ({} image(s))", what_, files_.size()); }

 private:
  std::vector<fs::path> files_;
  LoadOptions load_;
  std::string what_;
  size_t next_ = 0;
  std::chrono::steady_clock::time_point t0_ = std::chrono::steady_clock::now();
};

// A video file or a camera, through OpenCV's VideoCapture.
class VideoSequence final : public FrameSource {
 public:
  VideoSequence(std::unique_ptr<cv::VideoCapture> cap, const LoadOptions& load, std::string what, bool camera)
      : cap_(std::move(cap)), load_(load), what_(std::move(what)), camera_(camera) {}

  std::optional<Frame> next() override {
    cv::Mat pixels;
    if (!cap_->read(pixels) || pixels.empty()) return std::nullopt;
    Frame f;
    f.index = index_++;
    f.name = fmt::format("frame {}", f.index);
    f.time_s = camera_ ? seconds_since(t0_) : cap_->get(cv::CAP_PROP_POS_MSEC) / 1000.0;
    try {
      f.image = image_from_frame(pixels, load_, what_ + ", " + f.name);
    } catch (const std::exception& e) {
      f.problem = e.what();
    }
    return f;
  }

  std::string describe() const override {
    return fmt::format("{} ({}x{}, {:.0f} fps, {})", what_, int(cap_->get(cv::CAP_PROP_FRAME_WIDTH)),
                       int(cap_->get(cv::CAP_PROP_FRAME_HEIGHT)), cap_->get(cv::CAP_PROP_FPS),
                       cap_->getBackendName());
  }

 private:
  std::unique_ptr<cv::VideoCapture> cap_;
  LoadOptions load_;
  std::string what_;
  bool camera_;
  long index_ = 0;
  std::chrono::steady_clock::time_point t0_ = std::chrono::steady_clock::now();
};

std::vector<fs::path> image_files_in(const fs::path& folder) {
  std::vector<fs::path> files;
  for (const fs::directory_entry& e : fs::directory_iterator(folder))
    if (e.is_regular_file() && is_image_file_name(e.path().filename().string())) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

std::vector<fs::path> glob_files(const std::string& pattern) {
  glob_t g{};
  std::vector<fs::path> files;
  if (::glob(pattern.c_str(), 0, nullptr, &g) == 0)
    for (size_t i = 0; i < g.gl_pathc; ++i)
      if (fs::is_regular_file(g.gl_pathv[i])) files.emplace_back(g.gl_pathv[i]);
  ::globfree(&g);
  std::sort(files.begin(), files.end());
  return files;
}

std::unique_ptr<FrameSource> open_camera(const std::string& device, const LoadOptions& load,
                                         const CameraSettings& camera) {
  camera.validate();
  auto cap = std::make_unique<cv::VideoCapture>(device, cv::CAP_V4L2);
  if (!cap->isOpened())
    throw std::runtime_error(fmt::format(
        "cannot open camera {}: is it connected, and may this user read it (group video)?", device));
  const std::string& c = camera.fourcc;
  cap->set(cv::CAP_PROP_FOURCC, cv::VideoWriter::fourcc(c[0], c[1], c[2], c[3]));
  cap->set(cv::CAP_PROP_FRAME_WIDTH, camera.width_px);
  cap->set(cv::CAP_PROP_FRAME_HEIGHT, camera.height_px);
  cap->set(cv::CAP_PROP_FPS, camera.fps);
  return std::make_unique<VideoSequence>(std::move(cap), load, "camera " + device, true);
}

}  // namespace

std::unique_ptr<FrameSource> open_frame_source(const std::string& source, const LoadOptions& load,
                                               const CameraSettings& camera) {
  load.validate();
  if (source.rfind("/dev/video", 0) == 0) return open_camera(source, load, camera);
  std::error_code ec;
  if (fs::is_directory(source, ec)) {
    std::vector<fs::path> files = image_files_in(source);
    if (files.empty())
      throw std::runtime_error(fmt::format("folder {} holds no image (png, tif, jpg, exr, pgm, ppm, bmp)", source));
    return std::make_unique<FileSequence>(std::move(files), load, "folder " + source);
  }
  if (source.find_first_of("*?[") != std::string::npos) {
    std::vector<fs::path> files = glob_files(source);
    if (files.empty()) throw std::runtime_error(fmt::format("no file matches {}", source));
    return std::make_unique<FileSequence>(std::move(files), load, "files " + source);
  }
  if (!fs::is_regular_file(source, ec))
    throw std::runtime_error(fmt::format(
        "cannot read {}: no such file or folder (give a folder of images, a glob in quotes, a video file or "
        "/dev/videoN)",
        source));
  // One image is a sequence of one frame, decoded as measure decodes it
  // (its bit depth and colour tags), not through a video decoder.
  if (is_image_file_name(fs::path(source).filename().string()))
    return std::make_unique<FileSequence>(std::vector<fs::path>{source}, load, "image " + source);
  auto cap = std::make_unique<cv::VideoCapture>(source, cv::CAP_ANY);
  if (!cap->isOpened())
    throw std::runtime_error(fmt::format(
        "cannot decode {} as a video (nor is it a png, tif, tiff, jpg, jpeg, exr, pgm, ppm or bmp image): convert "
        "it to one of those",
        source));
  return std::make_unique<VideoSequence>(std::move(cap), load, "video " + source, false);
}

}  // namespace tactres
