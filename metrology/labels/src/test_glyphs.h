#pragma once
// Test support (metrology/labels tests and benchmark only): numbers rendered
// in real TrueType fonts with FreeType, and made to look like a camera saw
// them (ground and ink levels, blur, noise, orientation).

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "tactres/labels/label_reader.h"

namespace tactres::labels_test {

struct TestFont {
  std::string name;  // "DejaVu Sans"
  std::string path;  // the TTF file
};

// DejaVu Sans (fonts-dejavu-core) and Liberation Sans (fonts-liberation,
// Arial's metrics): both installed by scripts/install-deps.sh.
const std::vector<TestFont>& test_fonts();

// Ink coverage in [0, 1] (CV_32F) of `text` in `font`, scaled so its digits
// are `digit_height_px` tall, antialiased (rendered 4x larger, then
// area-averaged), with `margin_px` of empty ground on every side. Throws
// std::runtime_error when the font cannot be loaded.
cv::Mat render_text(const TestFont& font, const std::string& text, double digit_height_px, int margin_px);

struct CameraLook {
  double ground = 0.8;          // luminance of the ground
  double ink = 0.15;            // luminance of the ink
  double blur_sigma_px = 0.6;   // Gaussian optical blur
  double noise_sigma = 0.02;    // additive Gaussian noise, luminance units
  LabelOrientation orientation; // how the upright text appears
  std::uint64_t seed = 1;
};

// The coverage as a linear-luminance CV_32F patch seen by a camera.
cv::Mat camera_patch(const cv::Mat& coverage, const CameraLook& look);

}  // namespace tactres::labels_test
