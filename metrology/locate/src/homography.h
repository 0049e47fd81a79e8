#pragma once
// Plane homographies, private to locate: the one normalised (Hartley) DLT
// that the fiducial identification (fiducial_verify.cpp) and the pose's
// initial guesses (pose.cpp, pinhole_pose.cpp) fit, and the map itself.
//
// Not cv::findHomography: with more than 4 points it refines the DLT by
// Levenberg-Marquardt on the reprojection error (another estimator: ~0.02 px
// apart from the DLT on 5 fiducials with 0.05 px noise, ~1e-4 px on 4 exact
// ones), and it cannot return the one-parameter family that 4 points with a
// collinear triple leave (homography_dlt below), from which the fiducials'
// shapes pick the member.

#include <array>
#include <optional>
#include <span>

#include "tactres/targets/geometry.h"

namespace tactres::locate_detail {

// Row-major 3x3: (x, y, 1) -> H (x, y, 1), up to scale.
using Homography = std::array<double, 9>;

// H applied to p. *w_out, if given, receives the homogeneous w: positive on
// the side of the horizon where H's sign puts the scene in front.
Vec2 map_point(const Homography& H, Vec2 p, double* w_out = nullptr);

// d map_point / d p at p: [[a b] [c d]].
struct MapJacobian {
  double a = 0, b = 0, c = 0, d = 0;
};
MapJacobian map_jacobian(const Homography& H, Vec2 p);

// The normalised DLT's two smallest right singular vectors, de-normalised.
// Both keep the normalised vectors' unit norm (no rescaling), so mixtures
// c * least_squares + s * runner_up stay meaningful: with 4 points of which
// 3 are collinear the null space is two-dimensional and they span it.
struct DltSolution {
  Homography least_squares{};  // the smallest singular value's vector
  Homography runner_up{};      // the next one's
  double sv_largest = 0, sv_eighth = 0;  // singular values 1 and 8 (of 9)
  // One clear null direction (the points are in general position).
  bool unique() const { return sv_eighth > 1e-9 * sv_largest; }
};

// nullopt for fewer than 4 points, unequal spans, coincident points or a
// non-finite result.
std::optional<DltSolution> homography_dlt(std::span<const Vec2> from, std::span<const Vec2> to);

// Maps `from` onto `to`: exact for 4 points in general position, algebraic
// least squares for more. nullopt if degenerate (no clear null direction:
// collinear points, or 4 points of which 3 are collinear).
std::optional<Homography> fit_homography(std::span<const Vec2> from, std::span<const Vec2> to);

}  // namespace tactres::locate_detail
