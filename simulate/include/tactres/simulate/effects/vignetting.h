#pragma once
// Vignetting effect of the scene simulator: natural illumination fall-off,
// the "cos^4 law" (P. N. Slater (ed.), Photographic Systems for Engineers,
// SPSE, 1966; D. A. Kerr, "Derivation of the cosine fourth law for falloff
// of illuminance across a camera image", 2007; W. J. Smith, Modern Optical
// Engineering).
//
// Image irradiance of a uniformly radiant scene falls as cos^4 of the chief
// ray's field angle theta: one cosine from the obliquity of the entrance
// pupil, one from the obliquity of the image plane, two from the inverse
// square of the longer path. Real lenses deviate (pupil aberrations,
// mechanical vignetting), so the exponent is a parameter: 4 is the thin-lens
// law, smaller values mimic lenses designed to flatten the field.

#include <functional>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/matx.hpp>

namespace tactres {

struct VignettingOptions {
  double exponent = 4.0;  // n in cos^n(theta), [0, 8]

  void validate() const;  // throws std::invalid_argument
};

// image(x, y) *= cos_theta(x, y)^exponent. `image` is CV_32FC1 (in place);
// `cos_theta` is CV_32FC1 of the same size, each value the cosine of the
// chief-ray angle of that pixel, in [0, 1] (values up to 1 + 1e-6 are taken
// as 1; rounding of unit vectors). Throws std::invalid_argument for a type or
// size mismatch, or a value outside that range (naming the pixel).
void apply_vignetting(cv::Mat& image, const cv::Mat& cos_theta, const VignettingOptions& options);
void apply_vignetting(cv::Mat& image, const cv::Mat& cos_theta, double exponent = 4.0);

// Per-pixel cosine of the chief-ray angle for a width x height image, from a
// camera's unprojection: `unproject_ray(x_px, y_px)` returns a ray direction
// (any length) in the camera frame, z along the optical axis, for sensor
// pixel coordinates (mrcal's convention: the centre of the top-left pixel is
// (0, 0)). cos_theta = z / |ray|, clamped to [0, 1] (rays at or behind 90
// degrees receive no light).
//
// `pixel_scale` is the size of one image pixel in sensor pixels (a renderer
// supersampling by s passes 1.0 / s): image pixel (c, r) has its centre at
// sensor coordinates ((c + 0.5) pixel_scale - 0.5, (r + 0.5) pixel_scale - 0.5).
//
// Unprojection can be slow (iterative for distorted lenses), and cos theta is
// smooth, so it is evaluated every `grid_step` image pixels (and on the last
// row and column) and bilinearly interpolated in between; grid_step 1
// evaluates every pixel. The interpolation error is at most grid_step^2 / 8
// times (|d2/dx2| + |d2/dy2|) of cos theta in image pixels; for a pinhole of
// focal length f image pixels that is < grid_step^2 / (4 f^2) (2e-5 for an
// 8 px step at f = 900 px).
// Throws std::invalid_argument for a bad size, step or scale, or a
// non-finite / zero ray (naming the pixel).
cv::Mat cos_theta_map(int width, int height,
                      const std::function<cv::Vec3d(double x_px, double y_px)>& unproject_ray,
                      double pixel_scale = 1.0, int grid_step = 8);

}  // namespace tactres
