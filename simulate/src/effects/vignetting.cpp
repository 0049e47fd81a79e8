// Natural vignetting, cos^n of the chief-ray angle (cos^4 law; Slater 1966,
// Kerr 2007). See vignetting.h for the references.

#include "tactres/simulate/effects/vignetting.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>
#include <opencv2/core.hpp>

namespace tactres {

void VignettingOptions::validate() const {
  if (!(std::isfinite(exponent) && exponent >= 0.0 && exponent <= 8.0))
    throw std::invalid_argument(fmt::format(
        "vignetting: exponent must be in [0, 8] (4 is the cos^4 law), got {}", exponent));
}

void apply_vignetting(cv::Mat& image, const cv::Mat& cos_theta, const VignettingOptions& options) {
  options.validate();
  if (image.empty() || image.type() != CV_32FC1)
    throw std::invalid_argument(fmt::format(
        "apply_vignetting: the image must be a non-empty CV_32FC1 image, got type {} of {} x {}",
        image.type(), image.cols, image.rows));
  if (cos_theta.type() != CV_32FC1 || cos_theta.size() != image.size())
    throw std::invalid_argument(fmt::format(
        "apply_vignetting: cos_theta must be CV_32FC1 of the image's size {} x {}, got type {} of "
        "{} x {}",
        image.cols, image.rows, cos_theta.type(), cos_theta.cols, cos_theta.rows));
  // Validate everything before touching the image, so a failure leaves it intact.
  for (int y = 0; y < cos_theta.rows; ++y) {
    const float* c = cos_theta.ptr<float>(y);
    for (int x = 0; x < cos_theta.cols; ++x)
      if (!(c[x] >= 0.0f && c[x] <= 1.0f + 1e-6f))
        throw std::invalid_argument(fmt::format(
            "apply_vignetting: cos_theta at pixel (x {}, y {}) is {}, outside [0, 1]", x, y, c[x]));
  }
  const double n = options.exponent;
  const bool fourth = n == 4.0;
  for (int y = 0; y < image.rows; ++y) {
    float* p = image.ptr<float>(y);
    const float* c = cos_theta.ptr<float>(y);
    for (int x = 0; x < image.cols; ++x) {
      const double ct = std::min(1.0, static_cast<double>(c[x]));
      const double f = fourth ? (ct * ct) * (ct * ct) : std::pow(ct, n);
      p[x] = static_cast<float>(p[x] * f);
    }
  }
}

void apply_vignetting(cv::Mat& image, const cv::Mat& cos_theta, double exponent) {
  apply_vignetting(image, cos_theta, VignettingOptions{exponent});
}

cv::Mat cos_theta_map(int width, int height,
                      const std::function<cv::Vec3d(double x_px, double y_px)>& unproject_ray,
                      double pixel_scale, int grid_step) {
  if (width <= 0 || height <= 0)
    throw std::invalid_argument(
        fmt::format("cos_theta_map: the size must be positive, got {} x {}", width, height));
  if (!(std::isfinite(pixel_scale) && pixel_scale > 0.0 && pixel_scale <= 16.0))
    throw std::invalid_argument(fmt::format(
        "cos_theta_map: pixel_scale (image pixel size in sensor pixels) must be in (0, 16], got {}",
        pixel_scale));
  if (grid_step < 1 || grid_step > 256)
    throw std::invalid_argument(
        fmt::format("cos_theta_map: grid_step must be in 1..256 pixels, got {}", grid_step));
  if (!unproject_ray) throw std::invalid_argument("cos_theta_map: no unprojection function given");

  // Node positions along one axis: every grid_step pixels, plus the last one.
  auto nodes = [grid_step](int n) {
    std::vector<int> v;
    for (int i = 0; i < n - 1; i += grid_step) v.push_back(i);
    v.push_back(n - 1);
    return v;
  };
  const std::vector<int> xs = nodes(width), ys = nodes(height);

  cv::Mat at_nodes(static_cast<int>(ys.size()), static_cast<int>(xs.size()), CV_64FC1);
  for (std::size_t j = 0; j < ys.size(); ++j)
    for (std::size_t i = 0; i < xs.size(); ++i) {
      const double sx = (xs[i] + 0.5) * pixel_scale - 0.5;
      const double sy = (ys[j] + 0.5) * pixel_scale - 0.5;
      const cv::Vec3d ray = unproject_ray(sx, sy);
      const double len = cv::norm(ray);
      if (!std::isfinite(len) || len == 0.0)
        throw std::invalid_argument(fmt::format(
            "cos_theta_map: the unprojected ray at sensor pixel ({}, {}) is not a finite non-zero "
            "direction: the lens model cannot unproject there",
            sx, sy));
      at_nodes.at<double>(static_cast<int>(j), static_cast<int>(i)) =
          std::clamp(ray[2] / len, 0.0, 1.0);
    }

  cv::Mat out(height, width, CV_32FC1);
  std::size_t j = 0;
  for (int y = 0; y < height; ++y) {
    while (j + 2 < ys.size() && ys[j + 1] <= y) ++j;
    const std::size_t j1 = std::min(j + 1, ys.size() - 1);
    const double ty = ys[j1] == ys[j] ? 0.0 : double(y - ys[j]) / (ys[j1] - ys[j]);
    const double* row0 = at_nodes.ptr<double>(static_cast<int>(j));
    const double* row1 = at_nodes.ptr<double>(static_cast<int>(j1));
    float* o = out.ptr<float>(y);
    std::size_t i = 0;
    for (int x = 0; x < width; ++x) {
      while (i + 2 < xs.size() && xs[i + 1] <= x) ++i;
      const std::size_t i1 = std::min(i + 1, xs.size() - 1);
      const double tx = xs[i1] == xs[i] ? 0.0 : double(x - xs[i]) / (xs[i1] - xs[i]);
      const double top = row0[i] + tx * (row0[i1] - row0[i]);
      const double bottom = row1[i] + tx * (row1[i1] - row1[i]);
      o[x] = static_cast<float>(top + ty * (bottom - top));
    }
  }
  return out;
}

}  // namespace tactres
