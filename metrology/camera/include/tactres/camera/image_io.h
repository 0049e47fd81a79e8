#pragma once
// Image files in and out, through OpenImageIO.
//
// Loading follows an explicit policy (docs/CONVENTIONS.md, "Pixels"):
//  - any format OpenImageIO reads; integer formats are scaled to [0, 1] of
//    their full range, float formats are kept as they are;
//  - colour becomes Rec. 709 luminance of the linear values, or one channel;
//  - the transfer curve is explicit: forced, or what the file's colour tags
//    say, or by bit depth when it has none (transfer_curve.h);
//  - non-finite pixels follow a named policy: reject the image, or mask
//    them (NaN marks "no data" downstream and is never averaged).

#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>

#include <opencv2/core/mat.hpp>

#include "tactres/camera/transfer_curve.h"

namespace tactres {

// The input exists but cannot be used (truncated, undecodable, all NaN...).
// Maps to exit code 2; plain std::runtime_error (missing file) maps to 3.
class UnusableInput : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class NonFinitePolicy { reject, mask };

struct LoadOptions {
  int channel = -1;  // -1: luminance; else 0-based channel index
  std::optional<TransferCurve> transfer;  // nullopt: auto (tags, then bit depth)
  NonFinitePolicy non_finite = NonFinitePolicy::mask;
  // Turn the pixels as the file's Orientation tag (EXIF/TIFF, 1-8) says a
  // person sees them: chart mode names H and V as shown. Layout mode keeps
  // the stored grid, the sensor's, which its camera model describes.
  bool upright = false;
  void validate() const;
};

NonFinitePolicy non_finite_policy_from_string(const std::string& s);  // reject | mask

// The rounding of an integer file's code values, as noise in linear light
// (the classical quantisation model: each value is off by up to half a
// code step, uniformly, so its sd is step / sqrt(12) on the code scale,
// times the curve's slope at that level). A luminance mixed from colour
// channels carries the sum of the squared weights of that variance when
// each channel rounds on its own (0.56 for Rec. 709), all of it when they
// round alike (grey stored as RGB): the smaller is taken, so that this
// stays the least noise such a file can hold. A render with no noise of
// its own still has it wherever the light varies, and a noise estimate
// below it reads rounding luck.
struct CodeRounding {
  double code_step = 0;  // one code value on the [0, 1] scale the pixels were read on (the file's stated
                         // bit depth); 0: float data, none
  TransferCurve curve;   // the curve that maps codes to light
  double weight_sq = 1;  // sum of the squared weights of the channels in the luminance (1: one channel)
  double sd_at(double linear_level) const;  // the rounding's sd in linear light at that level (0 for float data)
};

struct LoadedImage {
  cv::Mat luminance;          // CV_32F, linear; NaN where masked
  int width = 0, height = 0, channels = 0;
  std::string pixel_format;   // e.g. "uint8", "uint16", "half", "float"
  int bits_per_sample = 0;
  bool integer_format = false;
  TransferDecision transfer;  // the curve applied, and why
  CodeRounding rounding;      // the code values' rounding, in linear light (noise floor)
  long long non_finite_pixels = 0;
  double saturation_level = 0;  // value at which integer pixels clip (1.0); 0 for float
  bool more_frames = false;     // the file holds more images of this size (a stack); only the first is read
  int orientation = 1;          // the file's Orientation tag (1: as stored)
  bool turned_upright = false;  // the pixels were turned as it says (LoadOptions::upright)
};

// Throws std::runtime_error (missing/unreadable file, exit 3) or
// UnusableInput (undecodable or truncated data, exit 2), naming the path.
LoadedImage load_image(const std::filesystem::path& path, const LoadOptions& options = {});

// A frame already in memory, from a camera or a video decoder: OpenCV's
// 8- or 16-bit grey or BGR(A), under the policy of a file with no colour
// tag (8-bit: sRGB, 16-bit: linear, unless options.transfer says). `what`
// names it in messages. Throws UnusableInput for another pixel type.
LoadedImage image_from_frame(const cv::Mat& frame, const LoadOptions& options, const std::string& what);

// Writes one channel, or 8-bit BGR colour, atomically. CV_32F goes out as float (TIFF/EXR only),
// CV_8U / CV_16U as integers; `bits` (<= 16) are the significant bits of a
// 16-bit image, scaled to the container's full range so readers see [0, 1].
void write_image(const std::filesystem::path& path, const cv::Mat& image, int bits = 0);

}  // namespace tactres
