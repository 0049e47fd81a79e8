#pragma once
// Reading the printed numbers of a USAF-1951 chart (its group and element
// labels: "-2" .. "9" in ordinary sans-serif numerals) with Tesseract, so
// chart mode can name the absolute group and element (docs/ARCHITECTURE.md,
// metrology/labels/).
//
// The contract:
// - A LabelReader owns one initialised Tesseract engine (LSTM, English
//   model, only "0123456789-" allowed, one line of text per image).
//   Initialisation costs 0.1-0.2 s: create one reader and reuse it. A
//   reader is NOT thread-safe: use one reader per thread.
// - Cost (tactres_labels_benchmark, this 2-core machine): one read ~1-1.5
//   ms, eight orientations ~12-22 ms, with OMP_THREAD_LIMIT=1; Debian's
//   Tesseract otherwise runs its LSTM on several OpenMP threads, which on
//   label-sized images costs 3-5x as much. A process that reads many
//   labels should set OMP_THREAD_LIMIT=1 in its environment (libgomp reads
//   it when the process starts, so the reader cannot set it).
// - Creation never throws for a missing or broken model: it returns the
//   reason as text (what is missing, which package or variable fixes it).
// - read_number() reads one number in a small grey patch in ONE orientation
//   (upright as given). read_number_any_orientation() tries all eight
//   (4 rotations x mirrored or not) and returns every credible reading.
// - A patch is single-channel CV_8U, CV_16U or CV_32F/CV_64F; float
//   patches are linear luminance, ideally in [0, 1] (any range works: the
//   contrast is normalised), non-finite pixels are ignored. The patch
//   should hold one number and little else: the reader drops ink that
//   touches the patch border when other ink is inside and bars of a
//   triplet, and refuses without calling Tesseract a patch whose ink does
//   not stand out of a flat ground, whose strokes are too thick for
//   numerals (unless read_number is asked to reopen a blurred numeral's
//   counters, see Counters), or that holds many separate blobs (noise,
//   texture, dust).
//   A lone bar may read as a "1": it looks like one.
// - "Nothing credible" is an empty result, never an exception: the text
//   is not one or two digits with an optional leading "-", or Tesseract's
//   confidence is below LabelReaderOptions::min_confidence, or the patch is
//   flat or cluttered.
//
// - Typefaces: ordinary sans-serif numerals read reliably (DejaVu Sans,
//   Liberation Sans, the numerals of real charts that use them); the blocky
//   numerals some chart makers use (a "6" like a "b") read only in part.
//
// Orientation. One label cannot always tell its orientation: "6" turned
// 180 deg is a "9", "0" and "8" look the same at 180 deg, "3" and "0"
// look the same flipped top to bottom (mirrored and turned 180 deg), a "2"
// flipped so looks much like a "5", and a "1" may read in several.
// So read_number_any_orientation() returns all candidates, best first, and
// a caller that holds several labels of one chart (they all share one
// orientation) decides with vote_orientation() and then takes each label's
// reading in that orientation with reading_in().

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace tactres {

// Which way the printed ink differs from the chart's ground.
enum class Ink {
  automatic,  // decided per patch: the class that fills the patch border is the ground
  dark,       // dark digits on a light ground (a positive chart)
  light,      // light digits on a dark ground (a negative chart)
};

// How the upright text appears in the image: mirrored left-right first when
// `mirrored`, then turned counter-clockwise by rotation_deg as seen on
// screen (image y down). The convention of tests/realdata/READINGS.md: a
// "2" whose base is a vertical stroke on the right and whose loop is on the
// left is {90, false}. Undoing it: turn clockwise by rotation_deg, then
// mirror left-right if `mirrored`.
struct LabelOrientation {
  int rotation_deg = 0;   // 0, 90, 180 or 270
  bool mirrored = false;
  bool operator==(const LabelOrientation&) const = default;
};
std::string to_string(LabelOrientation o);  // "0 deg", "90 deg mirrored"

// The eight orientations, in the order they are tried.
const std::vector<LabelOrientation>& all_label_orientations();

struct NumberReading {
  int value = 0;               // the number, e.g. 2, -1, 7
  std::string text;            // as read, e.g. "-1"
  double confidence = 0;       // Tesseract's, 0..100 (its least confident symbol)
  cv::Rect box_px;             // the ink read (the glyphs kept), in the input patch's pixels
  LabelOrientation orientation;  // how the text appears in the patch ({0, false} for read_number)
};

struct LabelReaderOptions {
  // Folder holding eng.traineddata. Empty: $TESSDATA_PREFIX when set, else
  // Debian's /usr/share/tesseract-ocr/5/tessdata (package tesseract-ocr-eng).
  std::string tessdata_dir;
  // Readings below this confidence are not credible (0..100). Clear digits
  // score ~85-99; so may a digit turned into the shape of another (see
  // "Orientation"), which only a vote over a chart's labels settles.
  double min_confidence = 60;
  // The character height, px, the patch is scaled to before OCR: Tesseract's
  // LSTM model reads best at ~30-40 px.
  double ocr_char_height_px = 36;
};

// What read_number does with a numeral whose strokes come out too thick at
// Otsu's threshold (a blob: under heavy blur the counters, the holes of a
// 0, 4, 6, 8 or 9, stand half-way between ink and ground and fill in):
// - keep (the default): refuse it, as read_number_any_orientation always
//   does;
// - reopen: binarise it again at Otsu's threshold within the ink class,
//   which splits the dark strokes from the half-tone counters, and read
//   that if the glyph stays whole (as many pieces, at least 3/4 of its
//   height) and its strokes are thin enough now. Rendered numerals 30 px
//   tall under 3-3.5 px of blur: 15 of 20 read reopened, 10 as they
//   stand, none wrong; at 4 px the reader misreads either way.
// Reopening also makes digits of some texture blobs: ask for it only where
// a number is expected and its reading is checked further (a group number
// where the chart's arrangement puts one, under a fibre bundle).
enum class Counters { keep, reopen };

class LabelReader;

// What LabelReader::create() gives: a reader, or why there is none.
struct LabelReaderOrError {
  std::unique_ptr<LabelReader> reader;  // null when creation failed
  std::string error;                    // empty on success; otherwise for people, with the fix
};

class LabelReader {
 public:
  // Initialises Tesseract (slow: do it once). Never throws for missing
  // data; throws std::invalid_argument for options out of range.
  static LabelReaderOrError create(const LabelReaderOptions& options = {});
  ~LabelReader();
  LabelReader(const LabelReader&) = delete;
  LabelReader& operator=(const LabelReader&) = delete;

  // The number in `patch` as it stands (no turning or mirroring), or
  // nullopt when nothing credible is read; `counters`: see Counters.
  // Throws std::invalid_argument for an empty or multi-channel patch.
  std::optional<NumberReading> read_number(const cv::Mat& patch, Ink ink = Ink::automatic,
                                           Counters counters = Counters::keep);

  // The box (patch pixels) of the glyphs read_number would read, whether
  // or not they then read as a number; nullopt where read_number refuses
  // the patch before reading (see the contract above). A caller that
  // finds them cut by the patch's edge can move the patch and read again.
  std::optional<cv::Rect> glyph_box(const cv::Mat& patch, Ink ink = Ink::automatic,
                                    Counters counters = Counters::keep) const;

  // Every credible reading over the eight orientations, highest confidence
  // first (empty when none is credible). Each carries the orientation in
  // which the text appears in the patch, and its box in the patch's own
  // pixels. The best one is front(), but see "Orientation" above: for a
  // single 6/9, 2/5, 0, 3, 8 or 1 the right answer may be a close second.
  std::vector<NumberReading> read_number_any_orientation(const cv::Mat& patch, Ink ink = Ink::automatic);

  const LabelReaderOptions& options() const { return options_; }

 private:
  struct Engine;
  LabelReader(std::unique_ptr<Engine> engine, const LabelReaderOptions& options);
  // The number in an upright OCR-ready image (8-bit, dark on white).
  std::optional<NumberReading> recognise(const cv::Mat& upright8);

  std::unique_ptr<Engine> engine_;
  LabelReaderOptions options_;
};

// The orientation the labels of one chart agree on: each orientation scores
// the sum over labels of that label's confidence in it (0 where it read
// nothing credible). nullopt when no label read anything.
struct OrientationVote {
  LabelOrientation orientation;
  double score = 0;            // the winner's summed confidence
  double runner_up_score = 0;  // the best other orientation's (close to `score`: undecided)
  int labels_read = 0;         // labels with a credible reading in the winning orientation
};
std::optional<OrientationVote> vote_orientation(const std::vector<std::vector<NumberReading>>& labels);

// A label's reading in orientation `o`, or null when it has none there.
const NumberReading* reading_in(const std::vector<NumberReading>& candidates, LabelOrientation o);

}  // namespace tactres
