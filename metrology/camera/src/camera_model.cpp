#include "tactres/camera/camera_model.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <new>
#include <regex>
#include <sstream>
#include <stdexcept>

#include "tactres/util/atomic_file.h"

extern "C" {
#include <mrcal/mrcal.h>
}

namespace tactres {

namespace {

struct FreeDeleter {
  void operator()(mrcal_cameramodel_t* p) const { std::free(p); }
};
using ModelPtr = std::unique_ptr<mrcal_cameramodel_t, FreeDeleter>;

// mrcal_cameramodel_t ends in a flexible array of intrinsics, so it is
// allocated with the C allocator at its full size.
ModelPtr allocate_model(const mrcal_lensmodel_t& lensmodel, int num_intrinsics) {
  const std::size_t bytes =
      sizeof(mrcal_cameramodel_t) + static_cast<std::size_t>(num_intrinsics) * sizeof(double);
  auto* p = static_cast<mrcal_cameramodel_t*>(std::calloc(1, bytes));
  if (p == nullptr) throw std::bad_alloc();
  p->lensmodel = lensmodel;
  return ModelPtr(p);
}

std::string lensmodel_name_of(const mrcal_lensmodel_t& lensmodel) {
  char buffer[256];
  if (!mrcal_lensmodel_name(buffer, sizeof buffer, &lensmodel))
    return mrcal_lensmodel_name_unconfigured(&lensmodel);
  return buffer;
}

std::string join_supported_names() {
  std::string out;
  for (const char* const* name = mrcal_supported_lensmodel_names(); *name != nullptr; ++name) {
    if (!out.empty()) out += ", ";
    out += *name;
  }
  return out;
}

// mrcal's parser only says "could not parse" (and prints details to stderr),
// so look for the common mistakes ourselves to give the user an actionable
// message. Returns an empty string if nothing specific was found.
std::string diagnose_cameramodel_text(const std::string& text) {
  if (text.find_first_not_of(" \t\r\n") == std::string::npos) return "the file is empty";
  for (const char* key : {"lensmodel", "intrinsics", "imagersize", "extrinsics"}) {
    if (text.find(std::string("'") + key + "'") == std::string::npos &&
        text.find(std::string("\"") + key + "\"") == std::string::npos)
      return std::string("the required key '") + key +
             "' is missing (a .cameramodel needs lensmodel, intrinsics, imagersize and extrinsics)";
  }
  std::smatch m;
  static const std::regex lens_re(R"(['"]lensmodel['"]\s*:\s*['"]([^'"]*)['"])");
  if (std::regex_search(text, m, lens_re)) {
    const std::string name = m[1].str();
    mrcal_lensmodel_t lensmodel;
    if (!mrcal_lensmodel_from_name(&lensmodel, name.c_str()) ||
        !mrcal_lensmodel_type_is_valid(lensmodel.type))
      return "unknown or incompletely configured lens model '" + name +
             "' (mrcal supports: " + join_supported_names() + ")";
    static const std::regex intr_re(R"(['"]intrinsics['"]\s*:\s*\[([^\]]*)\])");
    if (std::regex_search(text, m, intr_re)) {
      int count = 0;
      std::istringstream list(m[1].str());
      std::string item;
      while (std::getline(list, item, ','))
        if (item.find_first_not_of(" \t\r\n") != std::string::npos) ++count;
      const int expected = mrcal_lensmodel_num_params(&lensmodel);
      if (count != expected)
        return name + " needs " + std::to_string(expected) + " intrinsics but the file lists " +
               std::to_string(count);
    }
  }
  return {};
}

}  // namespace

struct CameraModel::Storage {
  ModelPtr model;
  int num_intrinsics = 0;
  mrcal_lensmodel_metadata_t meta{};

  Storage(ModelPtr m, int n) : model(std::move(m)), num_intrinsics(n) {
    meta = mrcal_lensmodel_metadata(&model->lensmodel);
  }
  std::unique_ptr<Storage> clone() const {
    ModelPtr copy = allocate_model(model->lensmodel, num_intrinsics);
    std::memcpy(copy.get(), model.get(),
                sizeof(mrcal_cameramodel_t) + static_cast<std::size_t>(num_intrinsics) * sizeof(double));
    return std::make_unique<Storage>(std::move(copy), num_intrinsics);
  }
};

namespace {

// Checks what mrcal itself does not: a usable imager size and finite,
// positive-focal intrinsics. `what` names the model in messages.
void validate_model(const mrcal_cameramodel_t& m, int num_intrinsics, const std::string& what) {
  if (m.imagersize[0] == 0 || m.imagersize[1] == 0 || m.imagersize[0] > 1000000 ||
      m.imagersize[1] > 1000000)
    throw std::invalid_argument(what + ": imager size " + std::to_string(m.imagersize[0]) + "x" +
                                std::to_string(m.imagersize[1]) +
                                " is not valid: width and height must be in [1, 1000000]");
  for (int i = 0; i < num_intrinsics; ++i)
    if (!std::isfinite(m.intrinsics[i]))
      throw std::invalid_argument(what + ": intrinsic parameter " + std::to_string(i) +
                                  " is not a finite number");
  const mrcal_lensmodel_metadata_t meta = mrcal_lensmodel_metadata(&m.lensmodel);
  if (meta.has_core && (m.intrinsics[0] <= 0.0 || m.intrinsics[1] <= 0.0))
    throw std::invalid_argument(what + ": focal lengths fx, fy must be positive, got " +
                                std::to_string(m.intrinsics[0]) + ", " +
                                std::to_string(m.intrinsics[1]));
}

}  // namespace

CameraModel::CameraModel(std::unique_ptr<Storage> storage, std::string source)
    : storage_(std::move(storage)), source_(std::move(source)) {}

CameraModel::CameraModel(const CameraModel& other)
    : storage_(other.storage_->clone()), source_(other.source_) {}

CameraModel& CameraModel::operator=(const CameraModel& other) {
  if (this != &other) {
    storage_ = other.storage_->clone();
    source_ = other.source_;
  }
  return *this;
}

CameraModel::CameraModel(CameraModel&&) noexcept = default;
CameraModel& CameraModel::operator=(CameraModel&&) noexcept = default;
CameraModel::~CameraModel() = default;

CameraModel CameraModel::load(const std::filesystem::path& path) {
  // read_file throws std::runtime_error naming the path if it is unreadable.
  const std::string text = read_file(path);
  return parse(text, path.string());
}

CameraModel CameraModel::parse(const std::string& text, const std::string& source_name) {
  const std::string what = "camera model " + source_name;
  // mrcal 2.2's parser reads past the end of its buffer (a crash) when a
  // quoted string or a '#' comment is still open at the end of the text
  // (found by fuzzing; a truncated .cameramodel does it). Refuse an open
  // string or a NUL byte, and end a final comment with a newline, before
  // mrcal sees the text. As in mrcal, a string ends at either quote.
  if (text.find('\0') != std::string::npos)
    throw std::invalid_argument(what + " is malformed: it holds a NUL byte (a .cameramodel is text)");
  char open = 0;  // 0 outside strings and comments; the quote or '#' that opened one
  for (const char c : text) {
    if (open == '#') open = c == '\n' ? 0 : open;
    else if (open) open = (c == '\'' || c == '"') ? 0 : open;
    else if (c == '#' || c == '\'' || c == '"') open = c;
  }
  if (open && open != '#')
    throw std::invalid_argument(what + " is malformed: a quoted string is not closed (is the file truncated?)");
  if (open == '#') return parse(text + "\n", source_name);
  // With len <= 0 mrcal expects a NUL-terminated buffer, which c_str() is.
  mrcal_cameramodel_t* raw = mrcal_read_cameramodel_string(
      text.c_str(), text.empty() ? 0 : static_cast<int>(text.size()));
  if (raw == nullptr) {
    std::string why = diagnose_cameramodel_text(text);
    if (why.empty())
      why = "mrcal could not parse it (its message above on stderr says where); expected the "
            "mrcal text format written by mrcal-calibrate-cameras";
    throw std::invalid_argument(what + " is malformed: " + why);
  }
  struct MrcalDeleter {
    void operator()(mrcal_cameramodel_t* p) const { mrcal_free_cameramodel(&p); }
  };
  std::unique_ptr<mrcal_cameramodel_t, MrcalDeleter> parsed(raw);
  const int n = mrcal_lensmodel_num_params(&parsed->lensmodel);
  if (n <= 0) throw std::invalid_argument(what + " is malformed: its lens model has no parameters");
  validate_model(*parsed, n, what + " is malformed");
  // Copy into our own allocation so every CameraModel frees the same way.
  ModelPtr copy = allocate_model(parsed->lensmodel, n);
  std::memcpy(copy->rt_cam_ref, parsed->rt_cam_ref, sizeof copy->rt_cam_ref);
  copy->imagersize[0] = parsed->imagersize[0];
  copy->imagersize[1] = parsed->imagersize[1];
  std::memcpy(copy->intrinsics, parsed->intrinsics, static_cast<std::size_t>(n) * sizeof(double));
  return CameraModel(std::make_unique<Storage>(std::move(copy), n), source_name);
}

CameraModel CameraModel::pinhole(double fx, double fy, double cx, double cy, int width, int height) {
  if (!(std::isfinite(fx) && fx > 0.0 && std::isfinite(fy) && fy > 0.0))
    throw std::invalid_argument("pinhole camera: focal lengths fx, fy must be positive and finite");
  if (!(std::isfinite(cx) && std::isfinite(cy)))
    throw std::invalid_argument("pinhole camera: principal point cx, cy must be finite");
  std::ostringstream name;
  name << "pinhole model (fx=" << fx << ", fy=" << fy << ", cx=" << cx << ", cy=" << cy << ")";
  CameraModel m = from_lens("LENSMODEL_PINHOLE", {fx, fy, cx, cy}, width, height);
  m.source_ = name.str();
  return m;
}

CameraModel CameraModel::from_lens(const std::string& lensmodel_name, std::vector<double> intrinsics,
                                   int width, int height) {
  mrcal_lensmodel_t lensmodel;
  if (!mrcal_lensmodel_from_name(&lensmodel, lensmodel_name.c_str()) ||
      !mrcal_lensmodel_type_is_valid(lensmodel.type))
    throw std::invalid_argument("unknown or incompletely configured lens model '" + lensmodel_name +
                                "' (mrcal supports: " + join_supported_names() + ")");
  const int n = mrcal_lensmodel_num_params(&lensmodel);
  if (n <= 0 || static_cast<std::size_t>(n) != intrinsics.size())
    throw std::invalid_argument(lensmodel_name + " needs " + std::to_string(n) +
                                " intrinsics (fx, fy, cx, cy, then distortion) but " +
                                std::to_string(intrinsics.size()) + " were given");
  if (width <= 0 || height <= 0)
    throw std::invalid_argument("camera imager size " + std::to_string(width) + "x" +
                                std::to_string(height) + " is not valid: both must be positive");
  ModelPtr m = allocate_model(lensmodel, n);
  m->imagersize[0] = static_cast<unsigned>(width);
  m->imagersize[1] = static_cast<unsigned>(height);
  std::memcpy(m->intrinsics, intrinsics.data(), intrinsics.size() * sizeof(double));
  validate_model(*m, n, lensmodel_name + " camera");
  return CameraModel(std::make_unique<Storage>(std::move(m), n), lensmodel_name + " model");
}

void CameraModel::save(const std::filesystem::path& path) const {
  AtomicOutput out(path);
  if (!mrcal_write_cameramodel_file(out.temp_path().c_str(), storage_->model.get()))
    throw std::runtime_error("cannot write camera model " + path.string() +
                             ": the folder is missing or not writable");
  out.commit();
}

int CameraModel::imager_width() const { return static_cast<int>(storage_->model->imagersize[0]); }
int CameraModel::imager_height() const { return static_cast<int>(storage_->model->imagersize[1]); }

std::string CameraModel::lensmodel_name() const { return lensmodel_name_of(storage_->model->lensmodel); }

bool CameraModel::is_pinhole() const {
  return storage_->model->lensmodel.type == MRCAL_LENSMODEL_PINHOLE;
}

std::vector<double> CameraModel::intrinsics() const {
  const double* p = storage_->model->intrinsics;
  return std::vector<double>(p, p + storage_->num_intrinsics);
}

std::size_t CameraModel::num_intrinsics() const {
  return static_cast<std::size_t>(storage_->num_intrinsics);
}

void CameraModel::check_image_size(int width, int height) const {
  if (width == imager_width() && height == imager_height()) return;
  throw std::invalid_argument("camera model " + source_ + " is for a " +
                              std::to_string(imager_width()) + "x" + std::to_string(imager_height()) +
                              " imager but the image is " + std::to_string(width) + "x" +
                              std::to_string(height) +
                              ": use the model calibrated for this camera, or resize/crop "
                              "consistently");
}

bool CameraModel::project_into(std::span<const Vec3> points_camera_mm, std::span<Vec2> px,
                               std::span<double> dpx_dpoint, std::span<double> dpx_dintrinsics,
                               std::span<std::uint8_t> valid) const {
  const std::size_t n = points_camera_mm.size();
  const std::size_t ni = num_intrinsics();
  if (px.size() != n || (!dpx_dpoint.empty() && dpx_dpoint.size() != 6 * n) ||
      (!dpx_dintrinsics.empty() && dpx_dintrinsics.size() != 2 * ni * n) ||
      (!valid.empty() && valid.size() != n))
    throw std::invalid_argument("CameraModel::project_into: output spans do not match the " +
                                std::to_string(n) + " input points");
  const bool want_gradients = !dpx_dpoint.empty() || !dpx_dintrinsics.empty();
  if (want_gradients && !storage_->meta.has_gradients)
    throw std::invalid_argument("camera model " + source_ + " uses " + lensmodel_name() +
                                ", for which mrcal has no gradients; the pose fit needs them: "
                                "recalibrate with another lens model (e.g. LENSMODEL_OPENCV8)");
  if (n == 0) return true;

  // Vec3/Vec2 and mrcal_point3_t/mrcal_point2_t are all plain arrays of
  // doubles; copy through small stack chunks instead of type-punning.
  constexpr std::size_t kChunk = 64;
  mrcal_point3_t p[kChunk];
  mrcal_point2_t q[kChunk];
  mrcal_point3_t dq_dp[2 * kChunk];
  const mrcal_cameramodel_t& m = *storage_->model;
  const bool behind_ok = storage_->meta.can_project_behind_camera;
  bool all_valid = true;
  for (std::size_t start = 0; start < n; start += kChunk) {
    const std::size_t count = std::min(kChunk, n - start);
    for (std::size_t i = 0; i < count; ++i) {
      const Vec3& v = points_camera_mm[start + i];
      p[i].x = v.x;
      p[i].y = v.y;
      p[i].z = v.z;
    }
    double* dq_di = dpx_dintrinsics.empty() ? nullptr : dpx_dintrinsics.data() + 2 * ni * start;
    if (dq_di == nullptr && !dpx_dpoint.empty()) {
      // mrcal 2.2 bug: with dq_dp but without dq_dintrinsics, mrcal_project
      // writes every point's dq/dp into the first slot. Asking for the
      // intrinsics gradient as well makes it fill every slot correctly.
      thread_local std::vector<double> scratch;
      scratch.resize(2 * ni * count);
      dq_di = scratch.data();
    }
    const bool ok = mrcal_project(q, dpx_dpoint.empty() ? nullptr : dq_dp, dq_di, p,
                                  static_cast<int>(count), &m.lensmodel, m.intrinsics);
    for (std::size_t i = 0; i < count; ++i) {
      const std::size_t k = start + i;
      px[k] = {q[i].x, q[i].y};
      // Pinhole-like models fold points behind the camera onto the image
      // (mrcal: "undefined values"), so those are marked invalid.
      bool good = ok && std::isfinite(q[i].x) && std::isfinite(q[i].y) &&
                  (behind_ok ? (p[i].x != 0.0 || p[i].y != 0.0 || p[i].z != 0.0) : p[i].z > 0.0);
      if (!dpx_dpoint.empty()) {
        double* g = dpx_dpoint.data() + 6 * k;
        for (int r = 0; r < 2; ++r)
          for (int c = 0; c < 3; ++c) {
            g[3 * r + c] = dq_dp[2 * i + r].xyz[c];
            good = good && std::isfinite(g[3 * r + c]);
          }
      }
      if (!valid.empty()) valid[k] = good ? 1 : 0;
      all_valid = all_valid && good;
    }
  }
  return all_valid;
}

std::vector<ProjectedPoint> CameraModel::project(std::span<const Vec3> points_camera_mm) const {
  const std::size_t n = points_camera_mm.size();
  std::vector<Vec2> px(n);
  std::vector<std::uint8_t> valid(n);
  project_into(points_camera_mm, px, {}, {}, valid);
  std::vector<ProjectedPoint> out(n);
  for (std::size_t i = 0; i < n; ++i) out[i] = {px[i], valid[i] != 0};
  return out;
}

std::vector<ProjectedPointWithGradient> CameraModel::project_with_gradient(
    std::span<const Vec3> points_camera_mm) const {
  const std::size_t n = points_camera_mm.size();
  std::vector<Vec2> px(n);
  std::vector<double> grad(6 * n);
  std::vector<std::uint8_t> valid(n);
  project_into(points_camera_mm, px, grad, {}, valid);
  std::vector<ProjectedPointWithGradient> out(n);
  for (std::size_t i = 0; i < n; ++i) {
    out[i].px = px[i];
    std::copy(grad.begin() + 6 * i, grad.begin() + 6 * i + 6, out[i].dpx_dpoint.begin());
    out[i].valid = valid[i] != 0;
  }
  return out;
}

std::vector<std::optional<Vec3>> CameraModel::unproject(std::span<const Vec2> px) const {
  const mrcal_cameramodel_t& m = *storage_->model;
  if (m.lensmodel.type == MRCAL_LENSMODEL_CAHVORE)
    throw std::invalid_argument("camera model " + source_ +
                                " uses LENSMODEL_CAHVORE, which mrcal cannot unproject");
  const std::size_t n = px.size();
  std::vector<std::optional<Vec3>> out(n);
  if (n == 0) return out;
  std::vector<mrcal_point2_t> q(n);
  std::vector<mrcal_point3_t> v(n);
  for (std::size_t i = 0; i < n; ++i) {
    q[i].x = px[i].x;
    q[i].y = px[i].y;
  }
  if (!mrcal_unproject(v.data(), q.data(), static_cast<int>(n), &m.lensmodel, m.intrinsics))
    return out;
  std::vector<Vec3> rays(n);
  std::vector<std::uint8_t> ok(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const double len = std::sqrt(v[i].x * v[i].x + v[i].y * v[i].y + v[i].z * v[i].z);
    if (std::isfinite(len) && len > 0.0) {
      rays[i] = Vec3{v[i].x / len, v[i].y / len, v[i].z / len};
      ok[i] = 1;
    }
  }
  // mrcal_unproject solves iteratively and does not flag a solve that did not
  // converge (e.g. where a distortion polynomial folds over), so a ray counts
  // only if it projects back onto its pixel.
  std::vector<Vec2> back(n);
  std::vector<std::uint8_t> back_valid(n);
  project_into(rays, back, {}, {}, back_valid);
  constexpr double kRoundTripTolerancePx = 1e-3;
  for (std::size_t i = 0; i < n; ++i)
    if (ok[i] && back_valid[i] && norm(back[i] - px[i]) <= kRoundTripTolerancePx) out[i] = rays[i];
  return out;
}

}  // namespace tactres
