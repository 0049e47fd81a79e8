#pragma once
// Where a live sequence's frames come from (`tactres watch SOURCE`):
//  - a folder of images, or a glob of them ("caps/*.png"), read in name
//    order through OpenImageIO (image_io.h: the same decoding policy as
//    `tactres measure`);
//  - a video file, decoded by OpenCV's VideoCapture;
//  - a V4L2 camera (/dev/videoN), opened through OpenCV with an explicit
//    frame size, rate and pixel format.
// Frames of a video or a camera carry no colour tag: 8-bit frames are
// taken as sRGB, 16-bit ones as linear, unless --transfer says otherwise
// (image_from_frame).
//
// A frame that cannot be decoded is returned with its problem instead of
// pixels: one bad file never ends the sequence.

#include <memory>
#include <optional>
#include <string>

#include "tactres/camera/image_io.h"

namespace tactres {

struct CameraSettings {
  int width_px = 1280, height_px = 720;  // requested frame size
  double fps = 30;                       // requested frame rate, (0, 1000]
  std::string fourcc = "MJPG";           // requested pixel format, 4 characters (e.g. MJPG, YUYV, GREY)
  void validate() const;                 // throws std::invalid_argument
};

struct Frame {
  long index = 0;      // 0-based position in the sequence
  std::string name;    // the file name, or "frame N"
  double time_s = 0;   // the video's timestamp; for files and cameras, seconds since the source opened
  std::optional<LoadedImage> image;  // empty: `problem` says why
  std::string problem;
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // The next frame; nullopt at the end of the sequence (never for a camera,
  // unless it stops delivering).
  virtual std::optional<Frame> next() = 0;
  // What the source is, for people: "folder x (120 images)", "video y.avi".
  virtual std::string describe() const = 0;
};

// Opens SOURCE: /dev/video*, a folder, a pattern with * ? or [, one image
// file (is_image_file_name: a sequence of one frame), or a video file.
// Throws std::runtime_error (exit 3) naming SOURCE and what to do when it
// does not exist, holds no image, or cannot be opened.
std::unique_ptr<FrameSource> open_frame_source(const std::string& source, const LoadOptions& load,
                                               const CameraSettings& camera = {});

// True for names OpenImageIO reads as single images (by extension).
bool is_image_file_name(const std::string& name);

}  // namespace tactres
