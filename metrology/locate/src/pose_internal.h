#pragma once
// Private to locate: what the two pose fits (pose.cpp: through a camera
// model; pinhole_pose.cpp: a pinhole fitted with the pose) share.

#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <ceres/ceres.h>

#include <Eigen/Dense>

#include "homography.h"
#include "tactres/locate/pose.h"

namespace tactres::locate_detail {

// The robust loss of the options (nullptr for none); the caller owns it.
ceres::LossFunction* make_loss(const PoseOptions& o);

// Throws std::invalid_argument for a disc with a non-finite centre or
// centroid or a non-positive radius.
void validate_discs(std::span<const DiscObservation> discs);
// The discs with a centroid, in order.
std::vector<std::size_t> observed_indices(std::span<const DiscObservation> discs);
std::string too_few_message(std::size_t found, std::size_t total);

// Solves a pose problem with the options' solver settings; the report goes
// to result.solver_report. False (with result.problem naming `what`, e.g.
// "the pose fit") when Ceres gave no usable solution: the parameters are
// then not to be read.
bool solve_pose_problem(ceres::Problem& problem, const PoseOptions& options, const std::string& what,
                        PoseResult& result, ceres::Solver::Summary& summary);

// Fills residuals, RMS and the side of the target from a converged rt.
// Returns false (with a message) if a disc cannot be projected at rt.
bool finish_result(const CameraModel& camera, std::span<const DiscObservation> discs,
                   const std::vector<std::size_t>& observed, const PoseOptions& options,
                   const RtCameraFromTarget& rt, PoseResult& result);

// The same matrix in Eigen's form.
Eigen::Matrix3d to_eigen(const Homography& H);

// H ~ [r1 r2 t] (target plane to normalised camera coordinates) -> rt, with
// the target (its mean point target_mean, mm) in front of the camera.
std::optional<RtCameraFromTarget> pose_from_homography(const Eigen::Matrix3d& H, Vec2 target_mean);

}  // namespace tactres::locate_detail
