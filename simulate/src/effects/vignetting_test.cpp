#include "tactres/simulate/effects/vignetting.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <doctest/doctest.h>
#include <opencv2/core.hpp>

using namespace tactres;

namespace {

// A pinhole camera: f = 300 px, principal point (320, 240).
cv::Vec3d pinhole_ray(double x, double y) { return {x - 320.0, y - 240.0, 300.0}; }

double pinhole_cos(double x, double y) {
  return 300.0 / std::sqrt((x - 320.0) * (x - 320.0) + (y - 240.0) * (y - 240.0) + 300.0 * 300.0);
}

}  // namespace

TEST_CASE("apply_vignetting: hand-computed cos^n factors") {
  cv::Mat image(1, 5, CV_32FC1, cv::Scalar(2.0));
  cv::Mat cos_theta(1, 5, CV_32FC1);
  const float values[5] = {1.0f, 0.6f, static_cast<float>(std::sqrt(0.5)), 0.0f, 1.0f + 5e-7f};
  for (int i = 0; i < 5; ++i) cos_theta.at<float>(0, i) = values[i];

  cv::Mat four = image.clone();
  apply_vignetting(four, cos_theta);  // default exponent 4
  CHECK(four.at<float>(0, 0) == doctest::Approx(2.0));
  CHECK(four.at<float>(0, 1) == doctest::Approx(2.0 * 0.1296).epsilon(1e-6));  // 0.6^4
  CHECK(four.at<float>(0, 2) == doctest::Approx(0.5).epsilon(1e-6));           // (1/sqrt 2)^4 = 1/4
  CHECK(four.at<float>(0, 3) == 0.0f);
  CHECK(four.at<float>(0, 4) == doctest::Approx(2.0));  // rounding above 1 is taken as 1

  cv::Mat two = image.clone();
  apply_vignetting(two, cos_theta, VignettingOptions{2.0});
  CHECK(two.at<float>(0, 1) == doctest::Approx(2.0 * 0.36).epsilon(1e-6));
  CHECK(two.at<float>(0, 2) == doctest::Approx(1.0).epsilon(1e-6));

  cv::Mat none = image.clone();
  apply_vignetting(none, cos_theta, 0.0);
  CHECK(none.at<float>(0, 1) == 2.0f);
}

TEST_CASE("apply_vignetting: rejects bad input and leaves the image intact") {
  cv::Mat image(3, 4, CV_32FC1, cv::Scalar(1.0));
  cv::Mat cos_theta(3, 4, CV_32FC1, cv::Scalar(0.9));
  CHECK_THROWS_AS(apply_vignetting(image, cos_theta, -1.0), std::invalid_argument);
  CHECK_THROWS_AS(apply_vignetting(image, cos_theta, 9.0), std::invalid_argument);
  cv::Mat small(2, 4, CV_32FC1, cv::Scalar(0.9));
  CHECK_THROWS_AS(apply_vignetting(image, small), std::invalid_argument);
  cv::Mat dbl(3, 4, CV_64FC1, cv::Scalar(0.9));
  CHECK_THROWS_AS(apply_vignetting(image, dbl), std::invalid_argument);

  for (float bad : {1.1f, -0.1f, std::numeric_limits<float>::quiet_NaN()}) {
    cv::Mat c = cos_theta.clone();
    c.at<float>(2, 1) = bad;
    try {
      apply_vignetting(image, c);
      FAIL("no throw");
    } catch (const std::invalid_argument& e) {
      CHECK(std::string(e.what()).find("(x 1, y 2)") != std::string::npos);
    }
    CHECK(cv::countNonZero(image != 1.0f) == 0);
  }
}

TEST_CASE("cos_theta_map: pinhole values, interpolation error, supersampling") {
  const int w = 640, h = 480;
  const cv::Mat exact = cos_theta_map(w, h, pinhole_ray, 1.0, 1);
  CHECK(exact.type() == CV_32FC1);
  CHECK(exact.size() == cv::Size(w, h));
  CHECK(exact.at<float>(240, 320) == doctest::Approx(1.0));
  CHECK(exact.at<float>(0, 0) == doctest::Approx(0.6));  // ray (-320, -240, 300), |ray| = 500
  CHECK(exact.at<float>(240, 620) == doctest::Approx(std::sqrt(0.5)));
  double worst_exact = 0.0;
  for (int y = 0; y < h; y += 7)
    for (int x = 0; x < w; x += 5)
      worst_exact = std::max(worst_exact, std::abs(exact.at<float>(y, x) - pinhole_cos(x, y)));
  CHECK(worst_exact < 1e-6);

  // Every 8th pixel, bilinear in between: error < 8^2 / (4 f^2) = 1.8e-4.
  const cv::Mat coarse = cos_theta_map(w, h, pinhole_ray);
  const double grid_error = cv::norm(coarse, exact, cv::NORM_INF);
  CHECK(grid_error < 64.0 / (4.0 * 300.0 * 300.0));
  CHECK(grid_error > 0.0);  // it did interpolate
  MESSAGE("cos_theta_map, 8 px grid, f = 300 px: max interpolation error " << grid_error);
  // Nodes (including the last row and column) are exact.
  CHECK(coarse.at<float>(16, 24) == exact.at<float>(16, 24));
  CHECK(coarse.at<float>(h - 1, w - 1) == exact.at<float>(h - 1, w - 1));
  CHECK(coarse.at<float>(h - 1, 3) == doctest::Approx(exact.at<float>(h - 1, 3)).epsilon(1e-5));

  // Supersampled by 2: image pixel (c, r) sits at sensor ((c + 0.5) / 2 - 0.5, ...).
  const cv::Mat fine = cos_theta_map(2 * w, 2 * h, pinhole_ray, 0.5, 1);
  CHECK(fine.at<float>(481, 641) == doctest::Approx(pinhole_cos(320.25, 240.25)).epsilon(1e-6));
  CHECK(fine.at<float>(0, 0) == doctest::Approx(pinhole_cos(-0.25, -0.25)).epsilon(1e-6));

  // Rays behind the camera get no light; failed unprojections are errors.
  const cv::Mat behind = cos_theta_map(4, 4, [](double, double) { return cv::Vec3d(1, 0, -1); });
  CHECK(cv::countNonZero(behind) == 0);
  try {
    cos_theta_map(10, 10, [](double x, double y) {
      return x > 5 && y > 5 ? cv::Vec3d(std::nan(""), 0, 1) : cv::Vec3d(0, 0, 1);
    }, 1.0, 1);
    FAIL("no throw");
  } catch (const std::invalid_argument& e) {
    CHECK(std::string(e.what()).find("(6, 6)") != std::string::npos);
  }
  CHECK_THROWS_AS(cos_theta_map(0, 4, pinhole_ray), std::invalid_argument);
  CHECK_THROWS_AS(cos_theta_map(4, 4, pinhole_ray, 1.0, 0), std::invalid_argument);
  CHECK_THROWS_AS(cos_theta_map(4, 4, pinhole_ray, -1.0), std::invalid_argument);
  // A one-pixel image works.
  CHECK(cos_theta_map(1, 1, pinhole_ray).at<float>(0, 0) == doctest::Approx(pinhole_cos(0, 0)));
}
