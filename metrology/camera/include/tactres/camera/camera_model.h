#pragma once
// CameraModel: an mrcal camera model (lens model + intrinsics + imager size).
//
// mrcal's C API is the only projection code in tactres (docs/CONVENTIONS.md):
// this class owns an mrcal_cameramodel_t and forwards every
// projection and unprojection to mrcal_project / mrcal_unproject, so any lens
// model mrcal supports works unchanged. The model's extrinsics (rt_cam_ref)
// are ignored: tactres uses intrinsics only and fits its own pose.
//
// Camera frame (mrcal): x right, y down, z forward along the optical axis, in
// millimetres here (projection is scale-free). Pixel coordinates follow mrcal:
// the centre of the top-left pixel is (0, 0).

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "tactres/targets/geometry.h"

namespace tactres {

// One projected point. `valid` is false where mrcal's result is meaningless:
// a point behind (or in the plane of) the camera for models that cannot
// project there, or a non-finite result.
struct ProjectedPoint {
  Vec2 px;
  bool valid = false;
};

// A projected point with d(px)/d(point), row-major 2x3:
// [dx/dX dx/dY dx/dZ; dy/dX dy/dY dy/dZ].
struct ProjectedPointWithGradient {
  Vec2 px;
  std::array<double, 6> dpx_dpoint{};
  bool valid = false;
};

class CameraModel {
 public:
  // Reads an mrcal .cameramodel file (as written by mrcal-calibrate-cameras).
  // Throws std::runtime_error naming the path if the file cannot be read, and
  // std::invalid_argument naming the path and the problem if it is malformed
  // (unknown lens model, wrong number of intrinsics, bad imager size, ...).
  static CameraModel load(const std::filesystem::path& path);
  // Parses the text of a .cameramodel; `source_name` names it in messages.
  static CameraModel parse(const std::string& text, const std::string& source_name);

  // An undistorted pinhole camera (LENSMODEL_PINHOLE). Throws
  // std::invalid_argument unless fx, fy > 0, cx, cy finite and width, height > 0.
  static CameraModel pinhole(double fx, double fy, double cx, double cy, int width, int height);

  // Any mrcal lens model by name (e.g. "LENSMODEL_OPENCV8",
  // "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=12_fov_x_deg=100") with
  // its intrinsics in mrcal order (core fx, fy, cx, cy first, then the
  // distortion parameters). Throws std::invalid_argument for an unknown name,
  // a wrong parameter count, non-finite values or a bad imager size.
  static CameraModel from_lens(const std::string& lensmodel_name, std::vector<double> intrinsics,
                               int width, int height);

  CameraModel(const CameraModel& other);
  CameraModel& operator=(const CameraModel& other);
  CameraModel(CameraModel&&) noexcept;
  CameraModel& operator=(CameraModel&&) noexcept;
  ~CameraModel();

  // Writes the model with mrcal_write_cameramodel_file, atomically (temporary
  // file, then rename). Throws std::runtime_error naming the path on failure.
  // Note: mrcal 2.2 writes every number with printf's "%f", i.e. 6 decimals;
  // a reloaded model can differ from this one by up to 5e-7 per parameter.
  void save(const std::filesystem::path& path) const;

  int imager_width() const;
  int imager_height() const;
  // The configured mrcal lens model name, e.g. "LENSMODEL_OPENCV8".
  std::string lensmodel_name() const;
  bool is_pinhole() const;
  // mrcal intrinsics: fx, fy, cx, cy, then the distortion parameters.
  std::vector<double> intrinsics() const;
  std::size_t num_intrinsics() const;
  // Where the model came from: the path given to load(), or a description.
  const std::string& source() const { return source_; }

  // Throws std::invalid_argument unless the image is width x height pixels:
  // a model calibrated on another resolution maps pixels wrongly.
  void check_image_size(int width, int height) const;

  // Projects camera-frame points to pixels.
  std::vector<ProjectedPoint> project(std::span<const Vec3> points_camera_mm) const;
  std::vector<ProjectedPointWithGradient> project_with_gradient(
      std::span<const Vec3> points_camera_mm) const;

  // Allocation-free projection for inner loops (the pose fit). px.size() must
  // equal points.size(). dpx_dpoint, if not empty, receives N x 2 x 3 values;
  // dpx_dintrinsics, if not empty, N x 2 x num_intrinsics() values; valid, if
  // not empty, one flag per point. Returns true if every point is valid.
  // Throws std::invalid_argument for wrong span sizes, and if gradients are
  // requested from a model mrcal has none for (CAHVORE).
  bool project_into(std::span<const Vec3> points_camera_mm, std::span<Vec2> px,
                    std::span<double> dpx_dpoint, std::span<double> dpx_dintrinsics,
                    std::span<std::uint8_t> valid) const;

  // Unit rays (camera frame) through the given pixels; nullopt where mrcal
  // cannot unproject (e.g. far outside the model's valid region). Throws
  // std::invalid_argument for models mrcal cannot unproject (CAHVORE).
  std::vector<std::optional<Vec3>> unproject(std::span<const Vec2> px) const;

 private:
  struct Storage;
  CameraModel(std::unique_ptr<Storage> storage, std::string source);
  std::unique_ptr<Storage> storage_;
  std::string source_;
};

}  // namespace tactres
