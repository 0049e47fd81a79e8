#pragma once
// The pose of the target in the camera: camera_from_target, fitted with Ceres
// from the imaged fiducial discs (docs/CONVENTIONS.md, "Frames and units").
//
// Convention (mrcal "rt"): rt = {r0, r1, r2, t0, t1, t2}, r a Rodrigues
// rotation vector in radians and t a translation in mm, such that
//   x_camera = R(r) * x_target + t.
// The target frame is the layout's: mm, origin at the top-left corner of the
// printed face, x right, y down, z into the target; the printed face is z = 0.
//
// Each fiducial disc is predicted by the area centroid of its PROJECTED image,
// not by the projection of its centre: under tilt and lens distortion the two
// differ by a few tenths of a pixel, more than the fit's accuracy. The
// projected disc is approximated by the polygon through `boundary_points`
// projected boundary points, its centroid by the shoelace formula, and the
// polygon's O(1/N^2) error is cancelled by one Richardson step with the
// polygon through every other vertex: (4 C_N - C_{N/2}) / 3.

#include <array>
#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "tactres/camera/camera_model.h"
#include "tactres/targets/geometry.h"
#include "tactres/targets/layout.h"

namespace tactres {

using RtCameraFromTarget = std::array<double, 6>;

// One fiducial disc of the layout and, if it was found, the centroid of its
// image in pixels (mrcal convention: top-left pixel centre is (0, 0)).
struct DiscObservation {
  Vec2 center_mm;
  double radius_mm = 0.0;
  std::optional<Vec2> centroid_px;
};

// The layout's fiducials as observations with no centroid yet, in layout order.
std::vector<DiscObservation> disc_observations(const std::vector<Fiducial>& fiducials);

enum class RobustLoss { none, huber, cauchy };

struct PoseOptions {
  // Vertices of the polygon that stands for each projected disc: even, in
  // [8, 4096]. At 48 the (extrapolated) centroid is within ~2e-5 px of the
  // exact one for a 1.2 mm disc at 35 degrees tilt (~1e-3 px without the
  // Richardson step), and ~1e-6 px for the default 0.6 mm discs.
  int boundary_points = 48;
  // Robust loss on each disc's 2-D residual, with its scale in px. Cauchy by
  // default: with 5 discs and 6 pose parameters there is little redundancy,
  // and a redescending loss keeps a misdetected disc from dragging the pose,
  // where Huber would still give it a linear pull. At 1 px, detections with
  // sub-pixel errors are weighted (almost) like plain least squares.
  RobustLoss loss = RobustLoss::cauchy;
  double loss_scale_px = 1.0;  // (0, 1000]
  int max_iterations = 200;    // [1, 10000]
  // The 6x6 covariance of rt (cheap: one dense 6x6 inverse).
  bool compute_covariance = true;
  // Start here instead of the homography guess (e.g. the previous frame's pose).
  std::optional<RtCameraFromTarget> initial_rt;

  // Throws std::invalid_argument naming the bad option and its valid range.
  void validate() const;
};

struct PoseResult {
  // False if there were too few discs, the geometry was degenerate or Ceres
  // gave no usable solution; `problem` then says why, and the numbers below
  // are not to be used (they hold the initial guess at best).
  bool usable = false;
  std::string problem;
  RtCameraFromTarget rt_camera_from_target_mm{};
  // RMS over observed discs of the residual length |observed - predicted|, px.
  double rms_px = 0.0;
  // observed - predicted centroid, px, one per observed disc; residuals_px[k]
  // belongs to discs[observed_disc_indices[k]].
  std::vector<Vec2> residuals_px;
  std::vector<std::size_t> observed_disc_indices;
  // Ceres' BriefReport() of the solve (empty if the solve never ran).
  std::string solver_report;
  // True if the camera is on the +z side of the target, i.e. it sees the
  // printed face from behind (through the gel): the image is mirrored.
  bool seen_from_behind = false;
  // Covariance of rt (rows/cols r0 r1 r2 t0 t1 t2; rad and mm), row-major,
  // for 1 px standard deviation per residual coordinate and evaluated with the
  // robust loss' weights: multiply by sigma_px^2 for the actual noise.
  std::optional<std::array<double, 36>> covariance_rt_per_px2;
};

// Fits camera_from_target. Needs >= 4 observed discs. The initial guess comes
// from a plane homography between the discs and their unprojected rays, so no
// user input is needed. Throws std::invalid_argument for invalid options or
// discs (non-positive radius, non-finite numbers); failures of the fit itself
// are reported in the result.
PoseResult fit_pose(const CameraModel& camera, std::span<const DiscObservation> discs,
                    const PoseOptions& options = {});

// Closed-form pose from >= 4 discs: normalised DLT homography between target
// (x, y) and the rays' (x/z, y/z), decomposed into a proper rotation and a
// translation with the target in front of the camera. Uses the disc centres
// (no centroid correction). nullopt if degenerate or fewer than 4 rays.
std::optional<RtCameraFromTarget> initial_pose_from_homography(std::span<const Vec2> target_mm,
                                                               std::span<const Vec3> rays_camera);

// Pixel of a target-frame point (z = 0); nullopt where it cannot be projected.
std::optional<Vec2> project_target_point(const CameraModel& camera, const RtCameraFromTarget& rt,
                                         Vec2 target_mm);
// Many target-frame points (z = 0) at once, for profile sampling.
std::vector<ProjectedPoint> project_target_points(const CameraModel& camera,
                                                  const RtCameraFromTarget& rt,
                                                  std::span<const Vec2> target_mm);

// Area centroid (px) of the image of the disc (center_mm, radius_mm) on the
// target face, from the projected polygon of `boundary_points` vertices with
// the Richardson step above. If dcentroid_drt is given it receives
// d(centroid)/d(rt), 2x6 row-major. nullopt if any boundary point cannot be
// projected or the image degenerates (disc seen edge-on). Throws
// std::invalid_argument unless boundary_points is even and >= 8 and
// radius_mm > 0.
std::optional<Vec2> project_disc_centroid(const CameraModel& camera, const RtCameraFromTarget& rt,
                                          Vec2 center_mm, double radius_mm,
                                          int boundary_points = 48,
                                          std::array<double, 12>* dcentroid_drt = nullptr);

// The camera centre in the target frame, mm.
Vec3 camera_center_in_target_mm(const RtCameraFromTarget& rt);

struct PinholePoseOptions {
  PoseOptions pose;
  // A weak Gaussian prior on the focal length keeps the fit well posed when
  // the view is (nearly) fronto-parallel: a plane seen square-on fixes only
  // focal/distance, not each one. 0 means max(width, height) (about a 53
  // degree horizontal field for a landscape imager); the prior's standard
  // deviation is prior_focal_sigma_rel times that, so tilted views are
  // decided by the data.
  double prior_focal_px = 0.0;          // 0 or (0, 1e6]
  double prior_focal_sigma_rel = 1.0;   // (0, 100]

  void validate() const;
};

struct PinholePoseResult {
  PoseResult pose;
  // The fitted pinhole camera (fx = fy = focal_px, principal point at the
  // image centre ((w-1)/2, (h-1)/2)); present when pose.usable. No lens
  // distortion is corrected with it.
  std::optional<CameraModel> camera;
  double focal_px = 0.0;
  // Standard deviation of focal_px for 1 px residual noise (prior included);
  // absent if Ceres could not compute the covariance.
  std::optional<double> focal_sigma_px_per_px;
  // False if the data hardly constrain the focal length (its posterior
  // sigma is more than half the prior's): the view is too close to
  // fronto-parallel, the focal length is the prior's, and only the
  // target-to-image mapping (which is what measurement needs) is determined.
  bool focal_determined_by_data = false;
};

// For when there is no camera model: fits a pinhole focal length (fx = fy,
// principal point fixed at the image centre) together with the pose, from
// >= 4 observed discs. Throws std::invalid_argument for a bad image size,
// options or discs.
PinholePoseResult fit_pinhole_and_pose(int image_width, int image_height,
                                       std::span<const DiscObservation> discs,
                                       const PinholePoseOptions& options = {});

}  // namespace tactres
