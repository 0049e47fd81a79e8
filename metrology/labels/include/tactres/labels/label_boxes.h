#pragma once
// Where the printed numbers may be in a region of a chart photograph: the
// boxes to crop and hand to LabelReader (label_reader.h).
//
// The contract:
// - Ink is found against the local mean (a window of ~3 character heights,
//   so uneven light does not matter) with the polarity the caller gives.
// - A glyph is a connected blob (8-connected) whose longer side lies in
//   [min_char_height_px, max_char_height_px] (any rotation: the longer side
//   of a digit is its height) and is not a bar. A bar is a filled rectangle
//   of aspect 2.5..8 (5 when sharp; blur widens thin bars) with a parallel
//   twin of about its size within three widths (a USAF triplet); a lone
//   filled stroke may be a "1" and is kept.
// - A minus sign is a short filled stroke (0.25..0.8 of the neighbouring
//   digit's height) lying across the digit's height axis beside it.
// - Glyphs become numbers: a digit alone, a minus and a digit, or two
//   digits of similar height side by side (along the digit's width axis,
//   whatever the rotation). Each glyph joins one number at most.
// - The boxes are axis-aligned, in image pixels, padded by a quarter of the
//   character height and clipped to the image; ordered top to bottom, then
//   left to right. No OCR is done here: a box may hold a blob that is no
//   digit, and LabelReader decides.

#include <vector>

#include <opencv2/core/mat.hpp>

#include "tactres/labels/label_reader.h"

namespace tactres {

struct LabelBoxSearch {
  cv::Rect search_px;              // where to look; clipped to the image (empty: the whole image)
  double min_char_height_px = 8;   // digit heights expected, px
  double max_char_height_px = 40;
  Ink ink = Ink::dark;             // dark or light; automatic is refused
  void validate() const;           // throws std::invalid_argument
};

// Candidate number boxes in `luminance` (single channel, CV_8U, CV_16U or
// CV_32F/CV_64F linear luminance). Throws std::invalid_argument for an
// empty or multi-channel image or an invalid search.
std::vector<cv::Rect> find_label_boxes(const cv::Mat& luminance, const LabelBoxSearch& search);

}  // namespace tactres
