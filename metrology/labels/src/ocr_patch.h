#pragma once
// A grey patch made ready for Tesseract (private to metrology/labels): the
// contrast normalised, the ink dark on white, stray ink removed, the text
// scaled to the OCR character height, binarised (Otsu; with
// Counters::reopen a blob is binarised again within the ink, see
// label_reader.h) and framed in white.

#include <optional>

#include <opencv2/core/mat.hpp>

#include "tactres/labels/label_reader.h"

namespace tactres::labels_detail {

struct OcrPatch {
  cv::Mat image;    // CV_8U: ink 0 on 255, with a white border
  cv::Rect text_px; // the glyphs kept, in the patch's pixels
};

// nullopt when the patch cannot hold a readable number: flat; ink that does
// not stand out of a flat ground (noise, texture); no glyph of at least
// 5 px; only bars; more than six separate blobs; or strokes too thick for
// numerals (blobs). Throws std::invalid_argument for an empty or multi-channel
// patch.
// With Counters::reopen, text whose strokes are too thick at Otsu's
// threshold is binarised again at Otsu's threshold within the ink, and
// kept only when it stays whole (as many pieces, 3/4 of its height) and
// its strokes are thin enough then.
std::optional<OcrPatch> prepare_ocr_patch(const cv::Mat& patch, Ink ink, double ocr_char_height_px,
                                          Counters counters = Counters::keep);

}  // namespace tactres::labels_detail
