#include "fuzz_entry_points.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "tactres/camera/camera_model.h"
#include "tactres/camera/image_io.h"
#include "tactres/measure/measure.h"
#include "tactres/measure/measurement_io.h"
#include "tactres/profiles/profile_fit.h"
#include "tactres/simulate/scene.h"
#include "tactres/reports/measurement_record.h"
#include "tactres/targets/coverage.h"
#include "tactres/targets/layout.h"
#include "tactres/targets/layout_json.h"

namespace tactres::fuzz {
namespace {

// A broken invariant of an accepted input: report and abort, which both
// libFuzzer and the replaying test treat as a failure.
[[noreturn]] void fail(const char* entry, const std::string& what) {
  std::fprintf(stderr, "fuzz entry %s: invariant broken: %s\n", entry, what.c_str());
  std::fflush(stderr);
  std::abort();
}

void require(bool ok, const char* entry, const std::string& what) {
  if (!ok) fail(entry, what);
}

std::string as_text(const std::uint8_t* data, std::size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

// Every number in a JSON document must be finite (tactres writes null for
// absent values, never NaN or Inf).
bool json_all_finite(const nlohmann::json& j) {
  if (j.is_number_float()) return std::isfinite(j.get<double>());
  if (j.is_structured())
    for (const auto& v : j)
      if (!json_all_finite(v)) return false;
  return true;
}

// Little-endian reader over the fuzz input; past the end it yields zeros.
class Bytes {
 public:
  Bytes(const std::uint8_t* d, std::size_t n) : d_(d), n_(n) {}
  template <class T>
  T get() {
    T v{};
    if (n_ - pos_ >= sizeof(T)) std::memcpy(&v, d_ + pos_, sizeof(T));
    pos_ = std::min(n_, pos_ + sizeof(T));
    return v;
  }
  std::size_t left() const { return n_ - pos_; }

 private:
  const std::uint8_t* d_;
  std::size_t n_, pos_ = 0;
};

// ---------------------------------------------------------------- JSON readers

void layout_json(const std::uint8_t* data, std::size_t size) {
  TargetLayout L;
  try {
    L = layout_from_json(parse_json_text(as_text(data, size), "fuzz layout"));
  } catch (const std::invalid_argument&) {
    return;
  }
  // What the measurement does with any accepted layout: index its artwork
  // and query it around every element.
  const ArtworkIndex index(L.artwork, 0.0);
  std::vector<int> hits;
  for (const ElementLayout& e : L.elements) index.query(e.extent_mm(), hits);
  const double inked = L.inked_area_mm2();
  require(!std::isnan(inked), "layout_json", "inked area is NaN");
  // An accepted layout must survive its own writer and reader.
  TargetLayout again;
  try {
    again = layout_from_json(nlohmann::json::parse(layout_to_json(L).dump()));
  } catch (const std::exception& e) {
    fail("layout_json", std::string("accepted layout does not read back: ") + e.what());
  }
  require(again.elements.size() == L.elements.size() && again.fiducials.size() == L.fiducials.size() &&
              again.artwork.size() == L.artwork.size(),
          "layout_json", "round trip changed the layout");
}

void scene_json(const std::uint8_t* data, std::size_t size) {
  Scene s;
  try {
    s = scene_from_json(parse_json_text(as_text(data, size), "fuzz scene"), "/nonexistent/fuzz/scene.json");
  } catch (const std::invalid_argument&) {
    return;
  }
  static const TargetLayout layout = make_layout({});
  const auto rt = s.rt_camera_from_target(layout);
  for (double v : rt) require(std::isfinite(v), "scene_json", "pose of an accepted scene is not finite");
  require(s.supersampling >= 1 && s.supersampling <= 16, "scene_json", "supersampling out of range");
}

void measurement_json(const std::uint8_t* data, std::size_t size) {
  MeasurementRecord r;
  try {
    r = measurement_from_json(parse_json_text(as_text(data, size), "fuzz measurement"), "fuzz measurement");
  } catch (const std::invalid_argument&) {
    return;
  }
  for (const ElementRecord& e : r.elements) {
    require(std::isfinite(e.lp_per_mm), "measurement_json", "element lp/mm not finite");
    if (e.m) require(std::isfinite(*e.m), "measurement_json", "m not finite");
    if (e.m_sigma) require(std::isfinite(*e.m_sigma), "measurement_json", "m_sigma not finite");
  }
  for (const LimitRecord* l : {&r.horizontal, &r.vertical}) {
    require(std::isfinite(l->lp_per_mm), "measurement_json", "limit not finite");
    if (l->interpolated_lp_per_mm)
      require(std::isfinite(*l->interpolated_lp_per_mm), "measurement_json", "interpolated limit not finite");
  }
}

// ---------------------------------------------------------------- camera model

void camera_model(const std::uint8_t* data, std::size_t size) {
  std::optional<CameraModel> cam;
  try {
    cam = CameraModel::parse(as_text(data, size), "fuzz.cameramodel");
  } catch (const std::invalid_argument&) {
    return;
  } catch (const std::runtime_error&) {
    return;
  }
  require(cam->imager_width() > 0 && cam->imager_height() > 0, "camera_model", "bad imager size accepted");
  require(cam->intrinsics().size() == cam->num_intrinsics(), "camera_model", "intrinsics count");
  // Use it the way measure does: project points in front of the camera and
  // unproject pixels. Results may be invalid, never a crash.
  const Vec3 pts[] = {{0, 0, 26}, {5, -3, 30}, {-12, 9, 20}, {0.1, 0.1, 1e-3}, {1, 1, -5}};
  try {
    for (const ProjectedPoint& p : cam->project(pts))
      if (p.valid) require(std::isfinite(p.px.x) && std::isfinite(p.px.y), "camera_model", "valid but not finite");
    const double w = cam->imager_width(), h = cam->imager_height();
    const Vec2 px[] = {{0, 0}, {w - 1, h - 1}, {0.5 * w, 0.5 * h}};
    for (const auto& ray : cam->unproject(px))
      if (ray) require(std::isfinite(ray->x) && std::isfinite(ray->y) && std::isfinite(ray->z), "camera_model",
                       "unprojected ray not finite");
  } catch (const std::invalid_argument&) {
    // Documented: models mrcal cannot unproject (CAHVORE).
  }
}

// ---------------------------------------------------------------- image decoding

void image(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return;
  static const char* kExt[] = {".png", ".tif", ".exr", ".jpg", ".pgm", ".bmp", ".hdr", ".tiff"};
  const std::uint8_t pick = data[0], opts = data[1];
  LoadOptions o;
  o.channel = int(opts & 3) - 1;  // -1 (luminance), 0, 1, 2
  const std::optional<TransferCurve> curves[] = {std::nullopt, TransferCurve::linear(), TransferCurve::srgb()};
  o.transfer = curves[(opts >> 2) % 3];
  o.non_finite = (opts & 16) ? NonFinitePolicy::reject : NonFinitePolicy::mask;
  static const std::filesystem::path dir = [] {
    auto d = std::filesystem::temp_directory_path() / ("tactres-fuzz-image-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  const std::filesystem::path file = dir / (std::string("input") + kExt[pick % std::size(kExt)]);
  {
    std::ofstream f(file, std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(data + 2), static_cast<std::streamsize>(size - 2));
  }
  LoadedImage img;
  try {
    img = load_image(file, o);
  } catch (const std::invalid_argument&) {  // --channel beyond the image's channels
    return;
  } catch (const std::runtime_error&) {  // includes UnusableInput
    return;
  }
  const cv::Mat& L = img.luminance;
  require(L.type() == CV_32F && L.cols == img.width && L.rows == img.height, "image", "luminance shape");
  long long nan = 0;
  for (int y = 0; y < L.rows; ++y)
    for (int x = 0; x < L.cols; ++x) {
      const float v = L.at<float>(y, x);
      require(!std::isinf(v), "image", "Inf pixel not masked");
      if (std::isnan(v)) ++nan;
      else if (img.integer_format) require(v >= -1e-6f && v <= 1.0f + 1e-5f, "image", "integer pixel outside [0, 1]");
    }
  require(nan == img.non_finite_pixels, "image", "non-finite count differs from the masked pixels");
  require(nan < static_cast<long long>(L.total()), "image", "all-NaN image accepted");
  if (o.non_finite == NonFinitePolicy::reject) require(nan == 0, "image", "reject policy let NaN through");
}

// ---------------------------------------------------------------- profile fit

// Input: u8 flags (bit 0 shading, bit 1 fit contrast, bit 2 fit shape);
// f64 contrast, beta_min, beta_max; i32 max_iterations (capped at 200 to
// keep executions fast); f64 start_nu0, start_beta; f64 u0_mm, bin_mm;
// i32 bin_count, fit_begin, fit_end; f64 bin_spread_var; u16 boxes, then
// (f64 u0, u1, level) each; u16 bins, then (f64 value, u_mean, sigma;
// i32 count) each. Doubles are raw IEEE bits: NaN, Inf and denormals
// arrive as they are.
void profile_fit(const std::uint8_t* data, std::size_t size) {
  Bytes b(data, size);
  const auto flags = b.get<std::uint8_t>();
  ProfileFitOptions o;
  o.signature = (flags & 1) ? Signature::shading : Signature::albedo;
  o.fit_contrast = flags & 2;
  o.fit_shape = flags & 4;
  o.contrast = b.get<double>();
  o.beta_min = b.get<double>();
  o.beta_max = b.get<double>();
  o.max_iterations = std::min(b.get<std::int32_t>(), 200);
  o.start_nu0_per_mm = b.get<double>();
  o.start_beta = b.get<double>();
  ProfileData d;
  d.u0_mm = b.get<double>();
  d.bin_mm = b.get<double>();
  d.bin_count = b.get<std::int32_t>();
  d.fit_begin = b.get<std::int32_t>();
  d.fit_end = b.get<std::int32_t>();
  d.bin_spread_var_mm2 = b.get<double>();
  const int boxes = b.get<std::uint16_t>();
  for (int k = 0; k < boxes && b.left() > 0; ++k) {
    IdealBox box;
    box.u0_mm = b.get<double>();
    box.u1_mm = b.get<double>();
    box.level = b.get<double>();
    d.ideal.push_back(box);
  }
  const int bins = b.get<std::uint16_t>();
  for (int k = 0; k < bins && b.left() > 0; ++k) {
    d.value.push_back(b.get<double>());
    d.u_mean_mm.push_back(b.get<double>());
    d.sigma.push_back(b.get<double>());
    d.count.push_back(b.get<std::int32_t>());
  }
  ProfileFit fit;
  try {
    fit = fit_profile(d, o);
  } catch (const std::invalid_argument&) {
    return;
  }
  if (!fit.usable) {
    require(!fit.problem.empty(), "profile_fit", "unusable fit without a reason");
    return;
  }
  require(std::isfinite(fit.nu0_per_mm) && fit.nu0_per_mm > 0, "profile_fit", "nu0 not finite and positive");
  require(std::isfinite(fit.beta), "profile_fit", "beta not finite");
  if (o.fit_shape) require(fit.beta >= o.beta_min - 1e-9 && fit.beta <= o.beta_max + 1e-9, "profile_fit", "beta out of bounds");
  require(std::isfinite(fit.var_log_nu0) && fit.var_log_nu0 >= 0, "profile_fit", "var(log nu0) not finite, >= 0");
  require(std::isfinite(fit.var_beta) && fit.var_beta >= 0, "profile_fit", "var(beta) not finite, >= 0");
  require(std::isfinite(fit.chi2_reduced) && fit.chi2_reduced >= 0, "profile_fit", "chi2 not finite, >= 0");
  require(std::isfinite(fit.contrast) && std::isfinite(fit.contrast_sigma), "profile_fit", "contrast not finite");
  require(std::isfinite(fit.b0) && std::isfinite(fit.b1_per_mm), "profile_fit", "background not finite");
  for (double f : {0.25, 1.0, 4.0}) {
    const double m = fit.transfer(f * fit.nu0_per_mm);
    require(std::isfinite(m) && m >= 0 && m <= 1, "profile_fit", "transfer not in [0, 1]");
    const double s = fit.transfer_sigma(f * fit.nu0_per_mm);
    require(std::isfinite(s) && s >= 0, "profile_fit", "transfer sigma not finite, >= 0");
  }
}

// ---------------------------------------------------------------- whole measurement

void measure_raw(const std::uint8_t* data, std::size_t size) {
  if (size < 9 || std::memcmp(data, "TRAW", 4) != 0) return;
  Bytes b(data + 4, size - 4);
  const int w = b.get<std::uint16_t>(), h = b.get<std::uint16_t>();
  const auto flags = b.get<std::uint8_t>();
  // Small images only: one execution must stay in the millisecond range.
  if (w < 1 || h < 1 || w > 640 || h > 480 || size < 9 + std::size_t(w) * h) return;
  LoadedImage img;
  img.width = w;
  img.height = h;
  img.channels = 1;
  img.pixel_format = "uint8";
  img.bits_per_sample = 8;
  img.integer_format = true;
  img.transfer = {TransferCurve::linear(), "test", false};
  img.rounding.code_step = 1.0 / 255;
  img.saturation_level = 1.0;
  img.luminance.create(h, w, CV_32F);
  const std::uint8_t* px = data + 9;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::uint8_t v = px[std::size_t(y) * w + x];
      float f = v / 255.0f;
      if ((flags & 1) && v == 255) f = std::numeric_limits<float>::quiet_NaN();
      if ((flags & 2) && v == 254) f = std::numeric_limits<float>::infinity();
      if (!std::isfinite(f)) {
        ++img.non_finite_pixels;
        f = std::numeric_limits<float>::quiet_NaN();
      }
      img.luminance.at<float>(y, x) = f;
    }
  if (img.non_finite_pixels == static_cast<long long>(w) * h) return;  // load_image refuses these
  static const TargetLayout layout = make_layout({});
  std::optional<CameraModel> cam;
  if (flags & 4) {
    const double f = 560.0 * w / 1280.0;
    cam = CameraModel::pinhole(f, f, 0.5 * (w - 1), 0.5 * (h - 1), w, h);
  }
  const Preset preset = std::array{Preset::fast, Preset::balanced, Preset::precise, Preset::fast}[(flags >> 3) & 3];
  const MeasureOptions options = MeasureOptions::for_preset(preset);
  Measurement m;
  try {
    m = measure_capture(img, layout, cam ? &*cam : nullptr, options);
  } catch (const std::invalid_argument& e) {
    fail("measure_raw", std::string("measure_capture threw on a valid call: ") + e.what());
  }
  MeasurementContext ctx;
  ctx.image = "fuzz.png";
  ctx.design = "fuzz";
  ctx.layout = "layout.json";
  ctx.tactres_version = "fuzz";
  ctx.loaded = &img;
  ctx.options = &options;
  const nlohmann::json j = measurement_to_json(m, ctx);
  require(json_all_finite(j), "measure_raw", "non-finite number in the measurement JSON");
  for (const ElementResult& e : m.elements) {
    require(std::isfinite(e.m) && std::isfinite(e.m_sigma) && std::isfinite(e.px_per_bar) &&
                std::isfinite(e.beta) && std::isfinite(e.chi2_reduced),
            "measure_raw", "non-finite element field");
    if (e.status == ElementStatus::ok) require(e.m_sigma > 0, "measure_raw", "ok element with m_sigma <= 0");
    if (e.resolved) require(e.status == ElementStatus::ok, "measure_raw", "resolved element not ok");
  }
  for (const Limit* l : {&m.horizontal, &m.vertical})
    if (l->uncertainty_lp_per_mm)
      require(std::isfinite(*l->uncertainty_lp_per_mm) && *l->uncertainty_lp_per_mm > 0, "measure_raw",
              "limit uncertainty not finite and positive");
  // What measure writes, the reports must read.
  try {
    (void)measurement_from_json(nlohmann::json::parse(j.dump()), "fuzz measurement");
  } catch (const std::exception& e) {
    fail("measure_raw", std::string("reports refuse measure's own JSON: ") + e.what());
  }
}

const Entry kEntries[] = {
    {"layout_json", layout_json, "layout_from_json + artwork index + round trip"},
    {"scene_json", scene_json, "scene_from_json + pose"},
    {"measurement_json", measurement_json, "measurement_from_json (reports)"},
    {"camera_model", camera_model, "CameraModel::parse + project/unproject"},
    {"image", image, "load_image on a temporary file with a chosen extension"},
    {"profile_fit", profile_fit, "fit_profile on arbitrary ProfileData"},
    {"measure_raw", measure_raw, "measure_capture on a raw 8-bit image"},
};

}  // namespace

std::span<const Entry> entries() { return kEntries; }

const Entry* find_entry(const std::string& name) {
  for (const Entry& e : kEntries)
    if (name == e.name) return &e;
  return nullptr;
}

namespace {
template <class T>
void put(std::string& s, T v) {
  s.append(reinterpret_cast<const char*>(&v), sizeof v);
}
}  // namespace

std::string encode_profile_fit(const ProfileData& d, const ProfileFitOptions& o) {
  std::string s;
  put<std::uint8_t>(s, static_cast<std::uint8_t>((o.signature == Signature::shading ? 1 : 0) |
                                                 (o.fit_contrast ? 2 : 0) | (o.fit_shape ? 4 : 0)));
  put(s, o.contrast);
  put(s, o.beta_min);
  put(s, o.beta_max);
  put<std::int32_t>(s, o.max_iterations);
  put(s, o.start_nu0_per_mm);
  put(s, o.start_beta);
  put(s, d.u0_mm);
  put(s, d.bin_mm);
  put<std::int32_t>(s, d.bin_count);
  put<std::int32_t>(s, d.fit_begin);
  put<std::int32_t>(s, d.fit_end);
  put(s, d.bin_spread_var_mm2);
  put<std::uint16_t>(s, static_cast<std::uint16_t>(d.ideal.size()));
  for (const IdealBox& b : d.ideal) {
    put(s, b.u0_mm);
    put(s, b.u1_mm);
    put(s, b.level);
  }
  put<std::uint16_t>(s, static_cast<std::uint16_t>(d.value.size()));
  for (std::size_t i = 0; i < d.value.size(); ++i) {
    put(s, d.value[i]);
    put(s, d.u_mean_mm[i]);
    put(s, d.sigma[i]);
    put<std::int32_t>(s, d.count[i]);
  }
  return s;
}

std::string encode_measure_raw(int width, int height, std::uint8_t flags, const std::uint8_t* pixels) {
  std::string s = "TRAW";
  const std::uint16_t w = static_cast<std::uint16_t>(width), h = static_cast<std::uint16_t>(height);
  s.append(reinterpret_cast<const char*>(&w), 2);
  s.append(reinterpret_cast<const char*>(&h), 2);
  s.push_back(static_cast<char>(flags));
  s.append(reinterpret_cast<const char*>(pixels), std::size_t(width) * height);
  return s;
}

}  // namespace tactres::fuzz
