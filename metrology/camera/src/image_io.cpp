#include "tactres/camera/image_io.h"

#include <cctype>
#include <cmath>
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <vector>

#include <OpenImageIO/imageio.h>
#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "tactres/util/atomic_file.h"

namespace tactres {

void LoadOptions::validate() const {
  if (channel < -1 || channel > 63)
    throw std::invalid_argument("--channel must be -1 (luminance) or a channel index 0..63");
}

NonFinitePolicy non_finite_policy_from_string(const std::string& s) {
  if (s == "reject") return NonFinitePolicy::reject;
  if (s == "mask") return NonFinitePolicy::mask;
  throw std::invalid_argument("unknown non-finite policy '" + s + "': use reject or mask");
}

namespace {

// The colour chunks of a PNG file (sRGB, iCCP, gAMA), read from the chunk
// list before the image data. OpenImageIO reports an untagged PNG as
// "sRGB", exactly as one with an sRGB chunk, so the chunks themselves are
// the only way to tell "says sRGB" from "says nothing".
struct PngColourChunks {
  bool srgb = false, iccp = false, gama = false;
};

PngColourChunks png_colour_chunks(const std::filesystem::path& path) {
  PngColourChunks found;
  std::ifstream in(path, std::ios::binary);
  unsigned char header[8];
  if (!in.read(reinterpret_cast<char*>(header), 8)) return found;
  // Colour chunks must precede IDAT (PNG spec, 5.6); stop there.
  for (int chunk = 0; chunk < 1000; ++chunk) {
    unsigned char head[8];
    if (!in.read(reinterpret_cast<char*>(head), 8)) break;
    const uint32_t length = (uint32_t(head[0]) << 24) | (uint32_t(head[1]) << 16) | (uint32_t(head[2]) << 8) | head[3];
    const std::string type(reinterpret_cast<const char*>(head + 4), 4);
    if (type == "IDAT" || type == "IEND") break;
    found.srgb |= type == "sRGB";
    found.iccp |= type == "iCCP";
    found.gama |= type == "gAMA";
    if (!in.seekg(std::streamoff(length) + 4, std::ios::cur)) break;  // data and CRC
  }
  return found;
}

// The file's explicit statement of its encoding, if it makes one.
ColourTag colour_tag_of(const std::filesystem::path& path, const OIIO::ImageInput& input,
                        const OIIO::ImageSpec& spec) {
  const std::string format = input.format_name();
  const float gamma = spec.get_float_attribute("oiio:Gamma", 0.0f);
  auto power_tag = [&](const std::string& what) {
    return ColourTag{true, TransferCurve::power(std::clamp(double(gamma), 0.2, 5.0)),
                     fmt::format("{} (gamma {:.3g})", what, gamma)};
  };
  if (format == "png") {
    const PngColourChunks c = png_colour_chunks(path);
    if (c.srgb) return {true, TransferCurve::srgb(), "PNG sRGB chunk"};
    // Reading an ICC profile's curves needs a colour-management library;
    // profiles in PNGs are overwhelmingly sRGB or close to it.
    if (c.iccp) return {true, TransferCurve::srgb(), "PNG iCCP profile (read as sRGB)"};
    if (c.gama && gamma > 0) return power_tag("PNG gAMA chunk");
    return {};
  }
  if (spec.find_attribute("ICCProfile")) return {true, TransferCurve::srgb(), "embedded ICC profile (read as sRGB)"};
  if (spec.get_int_attribute("Exif:ColorSpace", 0) == 1) return {true, TransferCurve::srgb(), "EXIF ColorSpace sRGB"};
  if (format == "openexr") return {true, TransferCurve::linear(), "OpenEXR (linear by definition)"};
  if (gamma > 0) return power_tag(format + " gamma attribute");
  return {};
}

std::string format_name(OIIO::TypeDesc t) {
  if (t == OIIO::TypeDesc::UINT8) return "uint8";
  if (t == OIIO::TypeDesc::UINT16) return "uint16";
  if (t == OIIO::TypeDesc::HALF) return "half";
  if (t == OIIO::TypeDesc::FLOAT) return "float";
  return t.c_str();
}

// The luminance (or one channel) of interleaved float pixels in [0, 1]
// through out.transfer, with the non-finite policy. `bgr`: colour comes in
// OpenCV's order.
void fill_luminance(const float* pixels, bool bgr, const LoadOptions& options, const std::string& what,
                    LoadedImage& out) {
  const TransferCurve& curve = out.transfer.curve;
  out.saturation_level = out.integer_format ? 1.0 : 0.0;
  out.luminance.create(out.height, out.width, CV_32F);
  const int nc = out.channels;
  const bool colour = options.channel < 0 && nc >= 3;
  const int r = bgr ? 2 : 0, b = bgr ? 0 : 2;
  // Rec. 709 luminance weights of linear R, G, B.
  constexpr float kR = 0.2126f, kG = 0.7152f, kB = 0.0722f;
  out.rounding.curve = curve;
  out.rounding.weight_sq = colour ? double(kR) * kR + double(kG) * kG + double(kB) * kB : 1.0;
  for (int y = 0; y < out.height; ++y) {
    float* row = out.luminance.ptr<float>(y);
    const float* src = pixels + static_cast<size_t>(y) * out.width * nc;
    for (int x = 0; x < out.width; ++x) {
      const float* p = src + static_cast<size_t>(x) * nc;
      auto lin = [&](float v) { return curve.to_linear(v); };
      float v;
      if (colour) v = kR * lin(p[r]) + kG * lin(p[1]) + kB * lin(p[b]);
      else v = lin(p[options.channel < 0 ? 0 : options.channel]);
      if (!std::isfinite(v)) {
        ++out.non_finite_pixels;
        v = std::numeric_limits<float>::quiet_NaN();
      }
      row[x] = v;
    }
  }
  const long long total = static_cast<long long>(out.width) * out.height;
  if (out.non_finite_pixels == total)
    throw UnusableInput(fmt::format("image {} has no finite pixel (all NaN or Inf): export the capture again, "
                                    "with its values as numbers",
                                    what));
  if (out.non_finite_pixels > 0 && options.non_finite == NonFinitePolicy::reject)
    throw UnusableInput(fmt::format(
        "image {} has {} non-finite pixel(s) (NaN/Inf); use --non-finite mask to measure around them", what,
        out.non_finite_pixels));
}

// Light cannot be negative. A float image whose darkest places lie below
// zero by more than kMaxNegativeShare of its brightest holds an offset or
// signed values, and every modulation would be read against the wrong
// black (one with 0.5 subtracted read G4E1 where the original reads G6E4).
// The places are 4x4-pixel means (two pyramid levels down), so that the
// noise about a black that was subtracted right does not count.
constexpr double kMaxNegativeShare = 0.05, kDarkestQuantile = 0.005;
void refuse_negative_light(const cv::Mat& luminance, const std::string& what) {
  cv::Mat places = luminance.clone();
  cv::patchNaNs(places, 0.0);  // masked pixels are neither dark nor bright
  for (int level = 0; level < 2 && std::min(places.cols, places.rows) >= 8; ++level) cv::pyrDown(places, places);
  std::vector<float> v(places.begin<float>(), places.end<float>());
  const auto quantile = [&](double q) {
    const auto at = v.begin() + static_cast<std::ptrdiff_t>(q * (v.size() - 1));
    std::nth_element(v.begin(), at, v.end());
    return static_cast<double>(*at);
  };
  const double darkest = quantile(kDarkestQuantile), brightest = quantile(1 - kDarkestQuantile);
  if (brightest <= 0)
    throw UnusableInput(fmt::format("image {} holds no light: its values are 0 or below almost everywhere "
                                    "(brightest places {:.3g}); export light as values of 0 and above",
                                    what, brightest));
  if (darkest < -kMaxNegativeShare * brightest)
    throw UnusableInput(fmt::format(
        "image {} holds negative light: its darkest places read {:.3g} against {:.3g} for its brightest. Linear "
        "light cannot be negative: the file carries an offset (a dark frame subtracted twice?) or signed values; "
        "shift it so that black is 0 and export it again",
        what, darkest, brightest));
}

// The luminance turned as the file's Orientation tag (EXIF/TIFF, 1-8)
// says a person sees it (the standard's "row 0 / column 0" table, as
// ImageMagick shows it); masked NaN pixels move with the rest. OpenCV's
// flips and turns: OpenImageIO 2.4's reorient swaps 5 and 7, and took 5 s
// more on a 120 Mpx frame.
void turn_upright(LoadedImage& image) {
  cv::Mat& m = image.luminance;
  switch (image.orientation) {
    case 2: cv::flip(m, m, 1); break;                                // mirrored left-right
    case 3: cv::rotate(m, m, cv::ROTATE_180); break;
    case 4: cv::flip(m, m, 0); break;                                // mirrored top-bottom
    case 5: cv::transpose(m, m); break;                              // mirrored, turned 270 clockwise
    case 6: cv::rotate(m, m, cv::ROTATE_90_CLOCKWISE); break;
    case 7: cv::transpose(m, m); cv::rotate(m, m, cv::ROTATE_180); break;  // mirrored, turned 90
    case 8: cv::rotate(m, m, cv::ROTATE_90_COUNTERCLOCKWISE); break;
    default: return;
  }
  image.width = m.cols;
  image.height = m.rows;
  image.turned_upright = true;
}

// The image library's message on one line (it joins its decoder's lines
// with newlines, which would break the JSON's one-line problem, the
// report's table and a CSV cell). A decoder that failed on every strip
// after a truncation says so once a strip: the first kMaxDecoderLines are
// kept, and the rest counted.
constexpr int kMaxDecoderLines = 2;
std::string one_line(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  int lines = 1;
  for (size_t k = text.find('\n'); k != std::string::npos; k = text.find('\n', k)) {
    if (++lines > kMaxDecoderLines) {
      const auto more = std::count(text.begin() + static_cast<std::ptrdiff_t>(k), text.end(), '\n');
      text = text.substr(0, k) + fmt::format("; and {} more such message(s)", more);
      break;
    }
    text.replace(k, 1, "; ");
  }
  return text;
}

// Whether what the decoder said while reading the pixels means they are
// damaged. libjpeg also warns about what it passes over harmlessly
// ("extraneous bytes before marker"): of its messages, only a premature end
// is damage. Every other decoder's error is.
bool pixels_damaged(const std::string& read_error, bool jpeg) {
  if (read_error.empty() || !jpeg) return !read_error.empty();
  std::string lower = read_error;
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
  return lower.find("premature end") != std::string::npos;
}

}  // namespace

LoadedImage load_image(const std::filesystem::path& path, const LoadOptions& options) {
  options.validate();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw std::runtime_error(fmt::format("cannot read image {}: {}", path.string(),
                                         std::filesystem::is_directory(path, ec)
                                             ? "it is a folder, not an image file (give the files in it)"
                                             : "no such file"));
  auto in = OIIO::ImageInput::open(path.string());
  if (!in)
    throw UnusableInput(fmt::format("cannot decode image {}: {} (is it a complete image file of a format "
                                    "OpenImageIO reads? re-export or copy it again)",
                                    path.string(), one_line(OIIO::geterror())));
  const OIIO::ImageSpec spec = in->spec();
  LoadedImage out;
  out.width = spec.width;
  out.height = spec.height;
  out.channels = spec.nchannels;
  out.pixel_format = format_name(spec.format);
  out.bits_per_sample = spec.get_int_attribute("oiio:BitsPerSample", static_cast<int>(spec.format.size() * 8));
  out.integer_format = !spec.format.is_floating_point();
  // OpenImageIO reads integers over their container's full range (signed
  // ones to [-1, 1], offset to [0, 1] below: half a step of [-1, 1]), and
  // stretches a smaller bit depth that the file states to it (a 12-bit
  // TIFF's step is 1/4095 of the range, not 1/65535).
  if (out.integer_format) {
    const int container_bits = static_cast<int>(spec.format.size() * 8);
    const bool fewer = !spec.format.is_signed() && out.bits_per_sample > 0 && out.bits_per_sample < container_bits;
    out.rounding.code_step =
        spec.format.is_signed() ? 0.5 / (std::exp2(container_bits - 1) - 1)
                                : 1.0 / (std::exp2(fewer ? out.bits_per_sample : container_bits) - 1);
  }
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0)
    throw UnusableInput(fmt::format("image {} has no pixels", path.string()));
  if (options.channel >= spec.nchannels)
    throw std::invalid_argument(fmt::format("--channel {} does not exist: {} has {} channel(s)",
                                            options.channel, path.string(), spec.nchannels));

  std::vector<float> pixels(static_cast<size_t>(spec.width) * spec.height * spec.nchannels);
  // A decoder may fill what it could not read and only say so: libtiff's
  // "Read error on strip", libjpeg's "Premature end of JPEG file" (a
  // truncated TIFF read its missing rows as black, with exit 0;
  // pixels_damaged).
  (void)in->geterror();  // what opening said (an unknown JFIF revision): the header, not the pixels
  const bool read = in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, pixels.data());
  const std::string read_error = in->has_error() ? in->geterror() : std::string();
  if (!read || pixels_damaged(read_error, std::string(in->format_name()) == "jpeg"))
    throw UnusableInput(fmt::format("cannot decode image {}: {} (the file is truncated or corrupt: copy or "
                                    "export it again)",
                                    path.string(), one_line(read_error)));

  // Signed integers (a laser-scanning microscope's int16) come as [-1, 1]:
  // offset to [0, 1], so that the format's minimum is black and clips, as an
  // unsigned one's 0 does (the tests of clipping and the level step assume
  // non-negative light).
  if (out.integer_format && spec.format.is_signed())
    for (float& v : pixels) v = 0.5f * (v + 1.0f);
  out.transfer = decide_transfer(options.transfer, colour_tag_of(path, *in, spec), out.integer_format,
                                 out.bits_per_sample);
  // The offset assumes where black lies, which the file does not say: the
  // reason says so wherever the curve is named.
  if (out.integer_format && spec.format.is_signed()) out.transfer.reason += "; signed, its minimum taken as black";
  // A second image of the first one's size is another frame of a stack (a
  // smaller one is a thumbnail). Only the second is looked at: each seek
  // walks a TIFF's chain of pages from the start.
  out.more_frames = in->seek_subimage(1, 0) && in->spec().width == spec.width && in->spec().height == spec.height;
  in->close();
  fill_luminance(pixels.data(), false, options, path.string(), out);
  if (!out.integer_format) refuse_negative_light(out.luminance, path.string());
  // Values outside 1..8 are reserved; viewers show such files as stored.
  out.orientation = spec.get_int_attribute("Orientation", 1);
  if (out.orientation < 1 || out.orientation > 8) out.orientation = 1;
  if (options.upright && out.orientation != 1) turn_upright(out);
  return out;
}

LoadedImage image_from_frame(const cv::Mat& frame, const LoadOptions& options, const std::string& what) {
  options.validate();
  const int depth = frame.depth();
  if (frame.empty() || (depth != CV_8U && depth != CV_16U) || frame.channels() > 4)
    throw UnusableInput(fmt::format("frame {} is not an 8- or 16-bit image of 1 to 4 channels", what));
  LoadedImage out;
  out.width = frame.cols;
  out.height = frame.rows;
  out.channels = frame.channels();
  out.pixel_format = depth == CV_8U ? "uint8" : "uint16";
  out.bits_per_sample = depth == CV_8U ? 8 : 16;
  out.integer_format = true;
  out.rounding.code_step = depth == CV_8U ? 1.0 / 255 : 1.0 / 65535;
  if (options.channel >= out.channels)
    throw std::invalid_argument(fmt::format("--channel {} does not exist: {} has {} channel(s)", options.channel,
                                            what, out.channels));
  // A frame from a camera or a decoder carries no colour tag here: the
  // bit-depth rule of files without one applies (transfer_curve.h).
  out.transfer = decide_transfer(options.transfer, ColourTag{}, true, out.bits_per_sample);
  cv::Mat scaled;
  frame.convertTo(scaled, CV_32F, depth == CV_8U ? 1.0 / 255 : 1.0 / 65535);
  if (!scaled.isContinuous()) scaled = scaled.clone();
  fill_luminance(scaled.ptr<float>(), out.channels >= 3, options, what, out);
  return out;
}

double CodeRounding::sd_at(double linear_level) const {
  if (!(code_step > 0) || !std::isfinite(linear_level)) return 0.0;
  // The light one code step spans about the level's code: the curve's
  // secant over the step, or over 2e-4 of the code range where the step is
  // finer (the curve is evaluated in float, which cannot resolve a 32-bit
  // step).
  const double span = std::max(code_step, 2e-4);
  const double code = curve.to_code(static_cast<float>(std::max(0.0, linear_level)));
  const double lo = std::clamp(code - 0.5 * span, 0.0, 1.0 - span);
  const double slope =
      (double(curve.to_linear(static_cast<float>(lo + span))) - curve.to_linear(static_cast<float>(lo))) / span;
  return std::abs(slope) * code_step * std::sqrt(weight_sq / 12.0);
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
