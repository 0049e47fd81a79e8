#pragma once
// Synthetic fiducial captures for the fiducial tests: the default target
// seen through a pinhole (rolled, tilted, mirrored, with barrel distortion),
// rendered by exact area coverage, with the effects a case asks for
// (printed discs, rings, crescents, blur, noise, an illumination gradient),
// and find_fiducials' result compared with the exact projected disc
// centroids.

#include <array>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "tactres/locate/fiducials.h"
#include "tactres/targets/geometry.h"
#include "tactres/targets/layout.h"

namespace tactres::fiducial_test {

using H3 = std::array<double, 9>;

// The test's own homography map (an oracle independent of locate's).
inline Vec2 map_h(const H3& H, Vec2 p) {
  const double w = H[6] * p.x + H[7] * p.y + H[8];
  return {(H[0] * p.x + H[1] * p.y + H[2]) / w, (H[3] * p.x + H[4] * p.y + H[5]) / w};
}

// A pinhole camera looking at the target's centre: target mm -> px.
// The target is rolled by roll_deg in its plane, then tilted by tilt_deg about
// an in-plane axis at tilt_axis_deg, seen from distance_mm with focal_px.
struct View {
  cv::Size size{800, 600};
  double focal_px = 1200;
  double distance_mm = 60;
  double roll_deg = 0;
  double tilt_deg = 0;
  double tilt_axis_deg = 0;
  bool mirrored = false;
  Vec2 shift_px{0, 0};  // image-plane shift of the target
  double k1 = 0;        // radial distortion: x_d = x (1 + k1 r^2), r in focal lengths
};

// Target mm -> px: the pinhole homography, then radial distortion about the
// principal point.
struct Projection {
  H3 H{};
  double k1 = 0;
  Vec2 principal_px;
  double focal_px = 1;
  Vec2 operator()(Vec2 mm) const {
    const Vec2 p = map_h(H, mm);
    if (k1 == 0) return p;
    const Vec2 u = (1 / focal_px) * (p - principal_px);
    return principal_px + (1 + k1 * dot(u, u)) * (p - principal_px);
  }
};

Projection projection(const TargetLayout& L, const View& v);

struct RenderSpec {
  double ground = 0.8, ink = 0.1;
  bool drop_fiducials = false;
  bool drop_patch = false;
  std::vector<std::string> hidden;  // fiducial ids not drawn (occluded)
  int supersample = 8;
};

// Area-coverage render: every artwork shape through P at `supersample`x, then
// INTER_AREA down (pixel i covers [i - 0.5, i + 0.5]). Straight edges are
// subdivided so that distortion bends them.
cv::Mat render(const TargetLayout& L, const Projection& P, cv::Size size, const RenderSpec& s);

struct Case {
  std::string name;
  TargetLayout layout;
  View view;
  RenderSpec spec;
  double noise_sigma = 0;  // in luminance units
  double blur_sigma_px = 0;
  bool gradient = false;  // 3:1 illumination across the image
  // Relief seen through a gel, shaded by the slope's magnitude: every edge
  // becomes a ring (dark, or light if ring_sign > 0).
  int ring_sign = 0;
  // Relief under one directional light (linearised Lambert): the slope along
  // the light, so each disc shows a light and a dark crescent.
  bool directional = false;
  double light_azimuth_deg = 0;  // in the image
};

struct Outcome {
  FiducialSearchResult result;
  Projection P;
  double max_err_px = 0;
  double rms_err_px = 0;
};

// The capture of a case through P.
cv::Mat make_image(const Case& c, const Projection& P);
// find_fiducials on the case's capture, and its centroids' errors.
Outcome run(const Case& c);
std::vector<std::string> ids(const FiducialSearchResult& r);

inline const std::vector<std::string> kAll{"TL", "T3", "TR", "BL", "BR"};

// Checks identification through geometry: each reported disc must be the
// one the truth homography puts there (not just the right set of names).
void check_all_found(const Outcome& o, double max_err_px);

// The default target, fronto-parallel, 800x600.
Case base_case(std::string name);

}  // namespace tactres::fiducial_test
