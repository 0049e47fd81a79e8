#include "tactres/metrology/image_io.h"

#include <cmath>
#include <filesystem>
#include <vector>

#include <OpenImageIO/imageio.h>
#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "tactres/targets/atomic_file.h"

namespace tactres {

void LoadOptions::validate() const {
  if (channel < -1 || channel > 63)
    throw std::invalid_argument("--channel must be -1 (luminance) or a channel index 0..63");
}

TransferCurve transfer_curve_from_string(const std::string& s) {
  if (s == "auto") return TransferCurve::automatic;
  if (s == "linear") return TransferCurve::linear;
  if (s == "srgb") return TransferCurve::srgb;
  throw std::invalid_argument("unknown transfer curve '" + s + "': use auto, linear or srgb");
}

NonFinitePolicy non_finite_policy_from_string(const std::string& s) {
  if (s == "reject") return NonFinitePolicy::reject;
  if (s == "mask") return NonFinitePolicy::mask;
  throw std::invalid_argument("unknown non-finite policy '" + s + "': use reject or mask");
}

namespace {

// IEC 61966-2-1 sRGB decoding.
float srgb_to_linear(float v) {
  return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}

std::string format_name(OIIO::TypeDesc t) {
  if (t == OIIO::TypeDesc::UINT8) return "uint8";
  if (t == OIIO::TypeDesc::UINT16) return "uint16";
  if (t == OIIO::TypeDesc::HALF) return "half";
  if (t == OIIO::TypeDesc::FLOAT) return "float";
  return t.c_str();
}

}  // namespace

LoadedImage load_image(const std::filesystem::path& path, const LoadOptions& options) {
  options.validate();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw std::runtime_error(fmt::format("cannot read image {}: no such file", path.string()));
  auto in = OIIO::ImageInput::open(path.string());
  if (!in)
    throw UnusableInput(fmt::format("cannot decode image {}: {} (is it a complete image file?)",
                                    path.string(), OIIO::geterror()));
  const OIIO::ImageSpec& spec = in->spec();
  LoadedImage out;
  out.width = spec.width;
  out.height = spec.height;
  out.channels = spec.nchannels;
  out.pixel_format = format_name(spec.format);
  out.bits_per_sample = spec.get_int_attribute("oiio:BitsPerSample", static_cast<int>(spec.format.size() * 8));
  out.integer_format = !spec.format.is_floating_point();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0)
    throw UnusableInput(fmt::format("image {} has no pixels", path.string()));
  if (options.channel >= spec.nchannels)
    throw std::invalid_argument(fmt::format("--channel {} does not exist: {} has {} channel(s)",
                                            options.channel, path.string(), spec.nchannels));

  std::vector<float> pixels(static_cast<size_t>(spec.width) * spec.height * spec.nchannels);
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, pixels.data()))
    throw UnusableInput(fmt::format("cannot decode image {}: {} (truncated or corrupt file?)",
                                    path.string(), in->geterror()));
  in->close();

  const std::string cs = spec.get_string_attribute("oiio:ColorSpace");
  const bool file_says_srgb = cs == "sRGB" || cs == "srgb";
  const bool srgb = options.transfer == TransferCurve::srgb ||
                    (options.transfer == TransferCurve::automatic && file_says_srgb);
  out.transfer_applied = srgb ? "srgb" : "linear";
  out.saturation_level = out.integer_format ? 1.0 : 0.0;

  out.luminance.create(spec.height, spec.width, CV_32F);
  const int nc = spec.nchannels;
  const bool colour = options.channel < 0 && nc >= 3;
  for (int y = 0; y < spec.height; ++y) {
    float* row = out.luminance.ptr<float>(y);
    const float* src = pixels.data() + static_cast<size_t>(y) * spec.width * nc;
    for (int x = 0; x < spec.width; ++x) {
      const float* p = src + static_cast<size_t>(x) * nc;
      auto lin = [&](float v) { return srgb ? srgb_to_linear(v) : v; };
      float v;
      if (colour) v = 0.2126f * lin(p[0]) + 0.7152f * lin(p[1]) + 0.0722f * lin(p[2]);
      else v = lin(p[options.channel < 0 ? 0 : options.channel]);
      if (!std::isfinite(v)) {
        ++out.non_finite_pixels;
        v = std::numeric_limits<float>::quiet_NaN();
      }
      row[x] = v;
    }
  }
  const long long total = static_cast<long long>(spec.width) * spec.height;
  if (out.non_finite_pixels == total)
    throw UnusableInput(fmt::format("image {} has no finite pixel (all NaN or Inf)", path.string()));
  if (out.non_finite_pixels > 0 && options.non_finite == NonFinitePolicy::reject)
    throw UnusableInput(fmt::format(
        "image {} has {} non-finite pixel(s) (NaN/Inf); use --non-finite mask to measure around them",
        path.string(), out.non_finite_pixels));
  return out;
}

void write_image(const std::filesystem::path& path, const cv::Mat& image, int bits) {
  CV_Assert(image.channels() == 1 || (image.channels() == 3 && image.depth() == CV_8U));
  OIIO::TypeDesc type;
  // `data` must never alias the caller's pixels: the conversions below
  // would otherwise write into the caller's image.
  cv::Mat data;
  if (image.channels() == 3) cv::cvtColor(image, data, cv::COLOR_BGR2RGB);  // OpenCV is BGR
  else data = image;
  switch (image.depth()) {
    case CV_8U: type = OIIO::TypeDesc::UINT8; break;
    case CV_16U:
      type = OIIO::TypeDesc::UINT16;
      if (bits > 0 && bits < 16) {  // scale significant bits to the full 16-bit range
        cv::Mat scaled;
        image.convertTo(scaled, CV_16U, 65535.0 / ((1 << bits) - 1));
        data = scaled;
      }
      break;
    case CV_32F: type = OIIO::TypeDesc::FLOAT; break;
    default: throw std::invalid_argument("write_image: unsupported pixel type");
  }
  const std::string ext = path.extension().string();
  if (type == OIIO::TypeDesc::FLOAT && !(ext == ".tif" || ext == ".tiff" || ext == ".exr"))
    throw std::invalid_argument(fmt::format(
        "{}: a float image needs .tif, .tiff or .exr (or add a sensor effect to quantise)", path.string()));
  AtomicOutput out(path);
  auto writer = OIIO::ImageOutput::create(out.temp_path().string());
  if (!writer)
    throw std::runtime_error(fmt::format("cannot write {}: no writer for this extension", path.string()));
  OIIO::ImageSpec spec(image.cols, image.rows, image.channels(), type);
  spec.attribute("oiio:ColorSpace", "Linear");  // tactres images hold linear values
  if (!writer->open(out.temp_path().string(), spec))
    throw std::runtime_error(fmt::format("cannot write {}: {}", path.string(), writer->geterror()));
  cv::Mat contiguous = data.isContinuous() ? data : data.clone();
  if (!writer->write_image(type, contiguous.data) || !writer->close())
    throw std::runtime_error(fmt::format("cannot write {}: {}", path.string(), writer->geterror()));
  out.commit();
}

}  // namespace tactres
