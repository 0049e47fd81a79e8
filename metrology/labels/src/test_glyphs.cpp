#include "test_glyphs.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <ft2build.h>
#include FT_FREETYPE_H

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "orientation.h"

namespace tactres::labels_test {

namespace {

constexpr int kSupersample = 4;

// One FreeType library and face, released on every path.
class Face {
 public:
  explicit Face(const std::string& path) {
    if (FT_Init_FreeType(&lib_) != 0) throw std::runtime_error("FreeType did not initialise");
    if (FT_New_Face(lib_, path.c_str(), 0, &face_) != 0) {
      FT_Done_FreeType(lib_);
      throw std::runtime_error("cannot load font " + path + " (scripts/install-deps.sh installs it)");
    }
  }
  ~Face() {
    FT_Done_Face(face_);
    FT_Done_FreeType(lib_);
  }
  Face(const Face&) = delete;
  Face& operator=(const Face&) = delete;
  FT_Face get() const { return face_; }

 private:
  FT_Library lib_ = nullptr;
  FT_Face face_ = nullptr;
};

FT_GlyphSlot load(FT_Face face, char c) {
  if (FT_Load_Char(face, static_cast<FT_ULong>(static_cast<unsigned char>(c)), FT_LOAD_RENDER) != 0)
    throw std::runtime_error(std::string("FreeType cannot render '") + c + "'");
  return face->glyph;
}

}  // namespace

const std::vector<TestFont>& test_fonts() {
  static const std::vector<TestFont> fonts{
      {"DejaVu Sans", "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf"},
      {"Liberation Sans", "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf"},
  };
  return fonts;
}

cv::Mat render_text(const TestFont& font, const std::string& text, double digit_height_px, int margin_px) {
  Face face(font.path);
  // The digits' height is a fixed share of the em, measured on an "8".
  constexpr int probe_ppem = 200;
  FT_Set_Pixel_Sizes(face.get(), 0, probe_ppem);
  const double digit_share = load(face.get(), '8')->bitmap.rows / static_cast<double>(probe_ppem);
  const int ppem = std::max(4, static_cast<int>(std::lround(kSupersample * digit_height_px / digit_share)));
  FT_Set_Pixel_Sizes(face.get(), 0, static_cast<FT_UInt>(ppem));

  const int pad = kSupersample * margin_px;
  const int baseline = pad + ppem;  // the ascent never exceeds one em here
  cv::Mat big = cv::Mat::zeros(2 * pad + ppem * 3 / 2, 2 * pad + ppem * static_cast<int>(text.size()), CV_8U);
  int pen_x = pad;
  for (char c : text) {
    const FT_GlyphSlot g = load(face.get(), c);
    const cv::Mat bitmap(static_cast<int>(g->bitmap.rows), static_cast<int>(g->bitmap.width), CV_8U,
                         g->bitmap.buffer, static_cast<size_t>(g->bitmap.pitch));
    const cv::Rect at(pen_x + g->bitmap_left, baseline - g->bitmap_top, bitmap.cols, bitmap.rows);
    if (!bitmap.empty()) {
      cv::Mat target = big(at);
      cv::max(target, bitmap, target);
    }
    pen_x += static_cast<int>(g->advance.x >> 6);
  }
  // Trim to the ink plus the margin, then area-average down.
  std::vector<cv::Point> ink;
  cv::findNonZero(big, ink);
  const cv::Rect box = (cv::boundingRect(ink) + cv::Size(2 * pad, 2 * pad) - cv::Point(pad, pad)) &
                       cv::Rect(0, 0, big.cols, big.rows);
  cv::Mat coverage;
  big(box).convertTo(coverage, CV_32F, 1.0 / 255);
  cv::resize(coverage, coverage, cv::Size(box.width / kSupersample, box.height / kSupersample), 0, 0,
             cv::INTER_AREA);
  return coverage;
}

cv::Mat camera_patch(const cv::Mat& coverage, const CameraLook& look) {
  cv::Mat patch = look.ground + (look.ink - look.ground) * coverage;
  if (look.blur_sigma_px > 0) cv::GaussianBlur(patch, patch, cv::Size(), look.blur_sigma_px);
  cv::Mat noise(patch.size(), CV_32F);
  cv::RNG rng(look.seed);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, look.noise_sigma);
  patch += noise;
  return labels_detail::orient(patch, look.orientation);
}

}  // namespace tactres::labels_test
