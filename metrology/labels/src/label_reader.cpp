#include "tactres/labels/label_reader.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <regex>
#include <stdexcept>

#include <omp.h>
#include <tesseract/baseapi.h>
#include <tesseract/resultiterator.h>

#include "ocr_patch.h"
#include "orientation.h"

namespace tactres {

namespace {

namespace fs = std::filesystem;
using labels_detail::OcrPatch;

constexpr const char* kDebianTessdata = "/usr/share/tesseract-ocr/5/tessdata";

std::string tessdata_dir(const LabelReaderOptions& options) {
  if (!options.tessdata_dir.empty()) return options.tessdata_dir;
  if (const char* env = std::getenv("TESSDATA_PREFIX"); env && *env) return env;
  return kDebianTessdata;
}

// The value of a credible text: an optional "-" and one or two digits, no
// leading zero ("07", "-0" are misreadings, not chart labels).
std::optional<int> number_value(const std::string& text) {
  static const std::regex number("-?[1-9][0-9]?|0");
  if (!std::regex_match(text, number)) return std::nullopt;
  return std::stoi(text);
}

}  // namespace

std::string to_string(LabelOrientation o) {
  return std::to_string(o.rotation_deg) + " deg" + (o.mirrored ? " mirrored" : "");
}

const std::vector<LabelOrientation>& all_label_orientations() {
  static const std::vector<LabelOrientation> all{{0, false},  {90, false}, {180, false}, {270, false},
                                                 {0, true},   {90, true},  {180, true},  {270, true}};
  return all;
}

struct LabelReader::Engine {
  tesseract::TessBaseAPI api;
};

LabelReader::LabelReader(std::unique_ptr<Engine> engine, const LabelReaderOptions& options)
    : engine_(std::move(engine)), options_(options) {}

LabelReader::~LabelReader() {
  if (engine_) engine_->api.End();
}

LabelReaderOrError LabelReader::create(const LabelReaderOptions& options) {
  if (!(options.min_confidence >= 0 && options.min_confidence <= 100))
    throw std::invalid_argument("labels: min_confidence must be in [0, 100]");
  if (!(options.ocr_char_height_px >= 16 && options.ocr_char_height_px <= 100))
    throw std::invalid_argument("labels: ocr_char_height_px must be in [16, 100]");
  const std::string dir = tessdata_dir(options);
  const fs::path model = fs::path(dir) / "eng.traineddata";
  std::error_code ec;
  if (!fs::is_regular_file(model, ec))
    return {nullptr, "Tesseract's English model is missing: no " + model.string() +
                         ". Install Debian's tesseract-ocr-eng (scripts/install-deps.sh), or set TESSDATA_PREFIX "
                         "(or LabelReaderOptions::tessdata_dir) to a folder holding eng.traineddata."};
  auto engine = std::make_unique<Engine>();
  // Dictionaries would pull digit strings towards words; they load only at
  // Init, so they are switched off there.
  const std::vector<std::string> names{"load_system_dawg", "load_freq_dawg"};
  const std::vector<std::string> values{"0", "0"};
  if (engine->api.Init(dir.c_str(), "eng", tesseract::OEM_LSTM_ONLY, nullptr, 0, &names, &values, false) != 0)
    return {nullptr, "Tesseract could not load " + model.string() +
                         " (damaged or not an LSTM model?). Reinstall Debian's tesseract-ocr-eng "
                         "(scripts/install-deps.sh)."};
  engine->api.SetVariable("tessedit_char_whitelist", "0123456789-");
  // The patch is prepared dark on white already; Tesseract's own retry of
  // an inverted image would only cost time.
  engine->api.SetVariable("tessedit_do_invert", "0");
  // One line of text: the single-word and raw-line modes lose more minus
  // signs and misread more lone digits on synthetic labels.
  engine->api.SetPageSegMode(tesseract::PSM_SINGLE_LINE);
  return {std::unique_ptr<LabelReader>(new LabelReader(std::move(engine), options)), ""};
}

namespace {

// What Tesseract read in the image it holds: the text and the least
// confident symbol's confidence. Symbols, not words: a word's confidence
// also weighs the alternatives the LSTM considered, and sinks for a clear
// "-1" whose minus sign is short. (Its LSTM symbol boxes are approximate,
// so a reading's box comes from the glyphs instead.)
NumberReading symbols(tesseract::TessBaseAPI& api) {
  NumberReading r;
  r.confidence = 100;
  std::unique_ptr<tesseract::ResultIterator> it(api.GetIterator());
  if (!it) return r;
  do {
    const std::unique_ptr<char[]> symbol(it->GetUTF8Text(tesseract::RIL_SYMBOL));
    if (!symbol) continue;
    r.text += symbol.get();
    r.confidence = std::min(r.confidence, static_cast<double>(it->Confidence(tesseract::RIL_SYMBOL)));
  } while (it->Next(tesseract::RIL_SYMBOL));
  return r;
}

}  // namespace

std::optional<NumberReading> LabelReader::recognise(const cv::Mat& upright8) {
  // Tesseract's LSTM runs OpenMP regions with a fixed thread count; on a
  // patch this small the threads cost 3-5x what they save. No active
  // parallel level while it reads (restored after; an OpenMP setting of the
  // process, but nothing else in tactres runs OpenMP regions).
  struct SerialOpenMp {
    int previous = omp_get_max_active_levels();
    SerialOpenMp() { omp_set_max_active_levels(0); }
    ~SerialOpenMp() { omp_set_max_active_levels(previous); }
  } serial;
  tesseract::TessBaseAPI& api = engine_->api;
  api.SetImage(upright8.data, upright8.cols, upright8.rows, 1, static_cast<int>(upright8.step));
  // The scaled text is ~36 px tall, a 9-point line at 300 dpi; saying so
  // keeps Tesseract from guessing (and warning about) a resolution.
  api.SetSourceResolution(300);
  NumberReading r;
  if (api.Recognize(nullptr) == 0) r = symbols(api);
  if (r.text.empty()) {
    // The line finder now and then drops a lone clear glyph; the
    // single-word mode does not (but may lose a minus sign, so it is only
    // the fallback).
    api.SetPageSegMode(tesseract::PSM_SINGLE_WORD);
    if (api.Recognize(nullptr) == 0) r = symbols(api);
    api.SetPageSegMode(tesseract::PSM_SINGLE_LINE);
  }
  api.Clear();
  const std::optional<int> value = number_value(r.text);
  if (!value || r.confidence < options_.min_confidence) return std::nullopt;
  r.value = *value;
  return r;
}

std::optional<NumberReading> LabelReader::read_number(const cv::Mat& patch, Ink ink, Counters counters) {
  const std::optional<OcrPatch> ocr =
      labels_detail::prepare_ocr_patch(patch, ink, options_.ocr_char_height_px, counters);
  if (!ocr) return std::nullopt;
  std::optional<NumberReading> r = recognise(ocr->image);
  if (r) r->box_px = ocr->text_px;
  return r;
}

std::optional<cv::Rect> LabelReader::glyph_box(const cv::Mat& patch, Ink ink, Counters counters) const {
  const std::optional<OcrPatch> ocr =
      labels_detail::prepare_ocr_patch(patch, ink, options_.ocr_char_height_px, counters);
  if (!ocr) return std::nullopt;
  return ocr->text_px;
}

std::vector<NumberReading> LabelReader::read_number_any_orientation(const cv::Mat& patch, Ink ink) {
  std::vector<NumberReading> found;
  const std::optional<OcrPatch> ocr = labels_detail::prepare_ocr_patch(patch, ink, options_.ocr_char_height_px);
  if (!ocr) return found;
  for (const LabelOrientation& o : all_label_orientations()) {
    const cv::Mat upright = labels_detail::make_upright(ocr->image, o);
    std::optional<NumberReading> r = recognise(upright);
    if (!r) continue;
    r->orientation = o;
    r->box_px = ocr->text_px;
    found.push_back(*r);
  }
  std::stable_sort(found.begin(), found.end(),
                   [](const NumberReading& a, const NumberReading& b) { return a.confidence > b.confidence; });
  return found;
}

const NumberReading* reading_in(const std::vector<NumberReading>& candidates, LabelOrientation o) {
  const auto it = std::find_if(candidates.begin(), candidates.end(),
                               [&](const NumberReading& r) { return r.orientation == o; });
  return it == candidates.end() ? nullptr : &*it;
}

std::optional<OrientationVote> vote_orientation(const std::vector<std::vector<NumberReading>>& labels) {
  std::vector<double> score(all_label_orientations().size(), 0.0);
  std::vector<int> read(score.size(), 0);
  for (const auto& candidates : labels)
    for (size_t i = 0; i < score.size(); ++i)
      if (const NumberReading* r = reading_in(candidates, all_label_orientations()[i])) {
        score[i] += r->confidence;
        ++read[i];
      }
  const size_t best = static_cast<size_t>(std::max_element(score.begin(), score.end()) - score.begin());
  if (score[best] <= 0) return std::nullopt;
  OrientationVote vote{all_label_orientations()[best], score[best], 0, read[best]};
  for (size_t i = 0; i < score.size(); ++i)
    if (i != best) vote.runner_up_score = std::max(vote.runner_up_score, score[i]);
  return vote;
}

}  // namespace tactres
