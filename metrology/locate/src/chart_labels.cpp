// The anchor from the chart's printed numbers (chart_detect.h, "Anchor"),
// read by OCR (labels/label_reader.h) in any ordinary typeface: the group
// numbers above the columns and the element numbers beside the elements.
//
// Each number read near an element is evidence for the absolute index of
// the largest element found (k = D.largest_index): as an element number v
// (1..6) of its nearest element r, it says (r + k) mod 6 = v - 1; as a group
// number v, it says one of the nearest elements lies in group v. Element
// numbers alone leave k open by whole groups (a tie between k and k + 6),
// so only a group number that fits breaks the tie. The k that most readings
// support wins, if no other k is as good; otherwise the anchor stays none.

#include <algorithm>
#include <cmath>
#include <limits>
#include <iterator>
#include <map>
#include <memory>
#include <mutex>
#include <optional>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "chart_detect_internal.h"
#include "tactres/labels/label_boxes.h"
#include "tactres/labels/label_reader.h"

namespace tactres::locate_detail {

namespace {

// Absolute indices the largest element found may have: groups -2..9.
constexpr int kMinIndex = -12, kMaxIndex = 59;
constexpr size_t kMaxBoxes = 40;
// A label counts (support, below) only within this many periods of its
// nearest element, and more than this many of its periods tall (as an
// element number; a group number must be over kMinGroupLabelPeriods, which
// label_boxes' pruning relies on being no less).
constexpr double kMaxLabelDistancePeriods = 8, kMinLabelPeriods = 0.5, kMinGroupLabelPeriods = 1.0;
static_assert(kMinGroupLabelPeriods >= kMinLabelPeriods);
// Under a fibre bundle (ChartDetection::fibre_lattice_pitch_px), the
// numbers are read on the detection's copy smoothed once more by this many
// lattice pitches (0.48 in all: the honeycomb keeps 1 % of its amplitude),
// and must read alike smoothed by kCheckSmoothingPitches instead (0.59 in
// all). On dev_01 and dev_02 in both encodings they anchor three of the
// four right, dev_01's 16-bit copy staying relative; with the pitch off by
// up to 4 % none is anchored wrong, where a single smoothing anchored
// dev_01 two groups high (docs/CHART.md).
constexpr double kNumberSmoothingPitches = 0.3, kCheckSmoothingPitches = 0.45;

Vec2 box_center(const cv::Rect& b) { return {b.x + 0.5 * b.width, b.y + 0.5 * b.height}; }

// Between its two patterns; a partial element's is its found pattern's.
Vec2 element_center(const ChartDetection& D, const ChartElement& e) {
  if (e.h < 0 || e.v < 0) return D.patterns[std::max(e.h, e.v)].center_px;
  return 0.5 * (D.patterns[e.h].center_px + D.patterns[e.v].center_px);
}

// The element nearest to `at_px` in its own periods, and that distance;
// null (and infinity) when there is none.
std::pair<const ChartElement*, double> nearest_element(const ChartDetection& D, const std::vector<ChartElement>& E,
                                                       Vec2 at_px) {
  const ChartElement* nearest = nullptr;
  double periods = std::numeric_limits<double>::infinity();
  for (const ChartElement& e : E)
    if (const double d = norm(at_px - element_center(D, e)) / e.period_px; d < periods) periods = d, nearest = &e;
  return {nearest, periods};
}

// Readers are made once and lent out, one per caller at a time:
// Tesseract's initialisation costs tens of ms, and a reader is not
// thread-safe. A pool, not one reader per thread: a worker thread of a
// batch's pool ends after Tesseract's own statics are gone, and its reader
// then made Tesseract print "WARNING! LEAK!" at every batch's exit.
class ReaderLease {
 public:
  ReaderLease() {
    {
      std::lock_guard<std::mutex> lock(pool().mutex);
      if (!pool().idle.empty()) {
        reader_ = std::move(pool().idle.back());
        pool().idle.pop_back();
        return;
      }
    }
    LabelReaderOrError made = LabelReader::create();  // tens of ms: not under the lock
    reader_ = std::move(made.reader);
    error_ = made.error;
  }
  ~ReaderLease() {
    if (!reader_) return;
    std::lock_guard<std::mutex> lock(pool().mutex);
    pool().idle.push_back(std::move(reader_));
  }
  ReaderLease(const ReaderLease&) = delete;
  ReaderLease& operator=(const ReaderLease&) = delete;
  LabelReader* get() const { return reader_.get(); }
  const std::string& error() const { return error_; }

 private:
  // Its first reader is made in its constructor: Tesseract makes its own
  // statics then, so they are complete before the pool is, and outlive it.
  struct Pool {
    std::mutex mutex;
    std::vector<std::unique_ptr<LabelReader>> idle;
    Pool() {
      if (LabelReaderOrError made = LabelReader::create(); made.reader) idle.push_back(std::move(made.reader));
    }
  };
  static Pool& pool() {
    static Pool p;
    return p;
  }
  std::unique_ptr<LabelReader> reader_;
  std::string error_;
};

struct Label {
  Vec2 center_px;
  int value = 0;
  double char_height_px = 0;
};

// The boxes that may hold numbers, within the elements' extent (grown by a
// few bar lengths: the labels sit beside and above the elements), the
// kMaxBoxes nearest to an element. A box that touches the image's border
// is no evidence: its number may be cut, and a cut number reads as
// another (dev_12's group number 3, its foot cut by the frame, reads as a
// confident 2 upright).
std::vector<cv::Rect> label_boxes(const cv::Mat& img, const ChartDetection& D, const std::vector<ChartElement>& kept) {
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300, w_min = 1e300, w_max = 0;
  for (const ChartElement& e : kept) {
    const Vec2 c = element_center(D, e);
    const double w = 0.5 * e.period_px, reach = 15 * w;
    x0 = std::min(x0, c.x - reach), y0 = std::min(y0, c.y - reach);
    x1 = std::max(x1, c.x + reach), y1 = std::max(y1, c.y + reach);
    w_min = std::min(w_min, w), w_max = std::max(w_max, w);
  }
  LabelBoxSearch search;
  search.search_px = cv::Rect(cv::Point(int(x0), int(y0)), cv::Point(int(x1), int(y1))) & cv::Rect(0, 0, img.cols, img.rows);
  search.min_char_height_px = std::max(6.0, 2 * w_min);
  search.max_char_height_px = std::max(search.min_char_height_px + 1, std::min(12 * w_max, 0.3 * std::min(img.cols, img.rows)));
  search.ink = D.light_bars ? Ink::light : Ink::dark;
  std::vector<cv::Rect> boxes = find_label_boxes(img, search);
  // Distance to the nearest element, in that element's periods: computed
  // once per box, not per comparison. A box that support() could not
  // count, whatever it reads, is not read (OCR is most of the anchor's
  // cost): farther than kMaxLabelDistancePeriods from every element, under
  // kMinLabelCharPx, or too small for its nearest element (the glyph read
  // lies within the box's square). Pruned before the kMaxBoxes nearest are
  // kept, so that where more boxes are found, no countable one is crowded
  // out by one too small.
  std::vector<std::pair<double, cv::Rect>> by_distance;
  for (const cv::Rect& b : boxes) {
    if (b.x <= 0 || b.y <= 0 || b.x + b.width >= img.cols || b.y + b.height >= img.rows) continue;
    const auto [nearest, periods] = nearest_element(D, kept, box_center(b));
    const int side_px = std::max(b.width, b.height);
    if (periods > kMaxLabelDistancePeriods || side_px < kMinLabelCharPx ||
        side_px <= kMinLabelPeriods * nearest->period_px)
      continue;
    by_distance.push_back({periods, b});
  }
  std::stable_sort(by_distance.begin(), by_distance.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  boxes.clear();
  for (size_t i = 0; i < by_distance.size() && i < kMaxBoxes; ++i) boxes.push_back(by_distance[i].second);
  return boxes;
}

// Every credible reading of every box, in each of the eight orientations.
std::vector<std::vector<NumberReading>> read_boxes(LabelReader& reader, const cv::Mat& img,
                                                   const std::vector<cv::Rect>& boxes, Ink ink) {
  std::vector<std::vector<NumberReading>> out;
  for (const cv::Rect& b : boxes) out.push_back(reader.read_number_any_orientation(img(b), ink));
  return out;
}

// The boxes that `wanted` names read upright only, turned (and
// un-mirrored) by the chart's orientation as the arrangement found it: one
// OCR pass a box, and no digit can be taken for another one turned (a 6
// for a 9, a 2 for a 5). Each box is read once per turn of the site's
// image.
const std::vector<std::vector<NumberReading>>& read_boxes_upright(LabelReader& reader, NumberSite& site, Ink ink,
                                                                  const ChartDetection::Arrangement& A,
                                                                  const std::vector<bool>& wanted) {
  const std::vector<cv::Rect>& boxes = *site.boxes;
  auto u = std::find_if(site.upright.begin(), site.upright.end(), [&](const NumberSite::Upright& t) {
    return t.mirrored == A.mirrored && norm(t.down_px - A.down_px) < 1e-9;
  });
  if (u == site.upright.end()) {
    site.upright.push_back({A.down_px, A.mirrored, std::vector<std::vector<NumberReading>>(boxes.size()),
                            std::vector<bool>(boxes.size(), false)});
    u = std::prev(site.upright.end());
  }
  for (size_t i = 0; i < boxes.size(); ++i) {
    if (!wanted[i] || u->done[i]) continue;
    const cv::Rect& b = boxes[i];
    const int side = std::max(b.width, b.height);
    if (auto n = reader.read_number(upright_patch(site.img, A, box_center(b), side, side), ink))
      u->read[i].push_back(*n);
    u->done[i] = true;
  }
  return u->read;
}

// The numbers as they read in orientation `o`.
std::vector<Label> labels_in(const std::vector<cv::Rect>& boxes, const std::vector<std::vector<NumberReading>>& read,
                             LabelOrientation o) {
  std::vector<Label> labels;
  for (size_t i = 0; i < boxes.size(); ++i)
    if (const NumberReading* r = reading_in(read[i], o)) {
      const bool upright = o.rotation_deg % 180 == 0;
      labels.push_back({box_center(boxes[i]), r->value,
                        double(upright ? r->box_px.height : r->box_px.width)});
    }
  return labels;
}

// For each candidate k, how many labels it explains (each label once), as
// element numbers and as group numbers. On MIL-STD-150A charts an
// element's number stands beside it, about one period (two bar widths)
// tall, and up to kMaxElementLabelPeriods in the finest groups, whose
// numbers the printing does not shrink as far as their bars (dev_03's "1"
// beside G7E1 is 2.6 periods tall); a group's number stands above its
// column, one to three periods of the group's first element tall. A label
// is read as either, only where its size and place allow it. Read only as
// a group number, that "1" made a copy of dev_03 shifted by (3, 5) px
// group -2, six groups off, on its own.
constexpr double kMaxElementLabelPeriods = 3.0;
// With the arrangement known, a group number stands only by a column's
// top (indices 1 and 6 modulo 12) or by the even group's element 1 (0).
bool group_number_place(int n) {
  const int n12 = mod12(n);
  return n12 == 0 || n12 == 1 || n12 == 6;
}

struct Support {
  int element = 0, group = 0;
  int total() const { return element + group; }
};

std::map<int, Support> support(const ChartDetection& D, const std::vector<ChartElement>& kept,
                               const std::vector<Label>& labels, std::optional<int> phase) {
  std::map<int, Support> votes;
  for (const Label& l : labels) {
    const auto [nearest, best] = nearest_element(D, kept, l.center_px);
    if (!nearest || best > kMaxLabelDistancePeriods) continue;
    const double size = l.char_height_px / nearest->period_px;
    if (l.char_height_px < kMinLabelCharPx) continue;
    const bool as_element =
        l.value >= 1 && l.value <= 6 && size > kMinLabelPeriods && size < kMaxElementLabelPeriods && best < 5;
    const bool as_group = size > kMinGroupLabelPeriods && size < 3.5 &&
                          (!phase || group_number_place(nearest->relative_index + *phase));
    for (int k = kMinIndex; k <= kMaxIndex; ++k) {
      const int n = nearest->relative_index + k;
      const bool element_fits = as_element && n - 6 * floor_div6(n) == l.value - 1;
      // A number that fits as the element's counts once, as that.
      const bool group_fits = !element_fits && as_group && floor_div6(n) == l.value;
      votes[k].element += element_fits;
      votes[k].group += group_fits;
    }
  }
  return votes;
}

struct Choice {
  int k = 0;
  Support s;
  LabelOrientation o;
  int labels_read = 0;
};

// Without the arrangement: the k that explains the most labels, clearly
// ahead of every other (element numbers alone tie k with k +- 6, so group
// numbers must break the tie twice over).
std::optional<Choice> choose_free(const std::vector<std::pair<Choice, std::map<int, Support>>>& by_o, int& best_n,
                                  int& second) {
  Choice best;
  best_n = 0;
  second = 0;
  for (const auto& [c, votes] : by_o)
    for (const auto& [k, v] : votes) {
      if (v.total() > best_n) {
        second = best_n, best_n = v.total();
        best = c, best.k = k, best.s = v;
      } else if (v.total() > second) {
        second = v.total();
      }
    }
  if (best_n < 3 || best_n < second + 2) return std::nullopt;
  return best;
}

// With the arrangement recognised, k is known modulo 12 (phase): the group
// numbers only choose among k = phase + 12 j, and the element numbers
// must not contradict the phase (their best reading, in any orientation,
// fits it as well as any other k).
std::optional<Choice> choose_with_phase(const std::vector<std::pair<Choice, std::map<int, Support>>>& by_o,
                                        int phase) {
  int element_best = 0;
  for (const auto& [c, votes] : by_o)
    for (const auto& [k, v] : votes) element_best = std::max(element_best, v.element);
  Choice best;
  bool any = false;
  int second = 0;  // the best group support of any other k
  for (const auto& [c, votes] : by_o)
    for (const auto& [k, v] : votes) {
      if (mod12(k - phase) != 0) continue;
      const bool better = !any || v.group > best.s.group || (v.group == best.s.group && v.element > best.s.element);
      if (better) {
        if (any && k != best.k) second = std::max(second, best.s.group);
        best = c, best.k = k, best.s = v, any = true;
      } else if (k != best.k) {
        second = std::max(second, v.group);
      }
    }
  if (!any || best.s.group < 1 || best.s.group < second + 1 || best.s.element < element_best) return std::nullopt;
  return best;
}

// The anchor from the numbers read in `img` at the detection's own scale;
// the numbers beside the elements are read beside the partial ones too.
// At least min_readings of them must fit the anchor chosen.
bool anchor_at_scale(ChartDetection& D, const std::vector<ChartElement>& kept,
                     const std::vector<ChartElement>& partial, NumberSite& site, std::optional<int> phase,
                     std::string& note, int min_readings = 1) {
  const cv::Mat& img = site.img;
  const ReaderLease lease;
  LabelReader* reader = lease.get();
  if (!reader) {
    note = "the printed numbers cannot be read: " + lease.error();
    return false;
  }
  if (phase) {
    // First where the arrangement puts the group numbers.
    std::string placed_note;
    if (const std::optional<int> k =
            index_from_placed_group_numbers(*reader, D, kept, partial, img, *phase, placed_note, min_readings)) {
      D.largest_index = *k;
      note = placed_note;
      return true;
    }
    note = placed_note + "; ";
  }
  std::vector<ChartElement> beside = kept;
  beside.insert(beside.end(), partial.begin(), partial.end());
  if (!site.boxes) site.boxes = label_boxes(img, D, beside);
  const std::vector<cv::Rect>& boxes = *site.boxes;
  const Ink ink = D.light_bars ? Ink::light : Ink::dark;
  std::vector<std::vector<NumberReading>> any_turn;
  const std::vector<std::vector<NumberReading>>* read = &any_turn;
  if (!phase) {
    any_turn = read_boxes(*reader, img, boxes, ink);
  } else {
    // With the phase known only a group number fixes k (choose_with_phase),
    // and one stands only by an element of index 0, 1 or 6 modulo 12
    // (support): those boxes are read first, and the others only where one
    // of them reads a group number that fits. (Each way of an ambiguous
    // arrangement read every box before: dev_02's three ways took 51 OCR
    // passes, nearly all to find that a wrong way fixes nothing; now 22.)
    std::vector<bool> by_group_place(boxes.size());
    for (size_t i = 0; i < boxes.size(); ++i)
      by_group_place[i] = group_number_place(nearest_element(D, beside, box_center(boxes[i])).first->relative_index +
                                             *phase);
    read = &read_boxes_upright(*reader, site, ink, D.arrangement, by_group_place);
    const std::map<int, Support> votes = support(D, beside, labels_in(boxes, *read, {}), phase);
    const bool group_fits = std::any_of(votes.begin(), votes.end(), [&](const auto& kv) {
      return mod12(kv.first - *phase) == 0 && kv.second.group >= 1;
    });
    if (group_fits)
      read = &read_boxes_upright(*reader, site, ink, D.arrangement, std::vector<bool>(boxes.size(), true));
  }
  // The orientation and k together: in the wrong orientation the numbers
  // (a 6 read as 9, a 2 as 5) do not fit the elements' order.
  std::vector<std::pair<Choice, std::map<int, Support>>> by_o;
  for (const LabelOrientation& o : all_label_orientations()) {
    if (phase && !(o == LabelOrientation{})) continue;  // read upright already
    const std::vector<Label> labels = labels_in(boxes, *read, o);
    Choice c;
    c.o = o;
    c.labels_read = static_cast<int>(labels.size());
    by_o.push_back({c, support(D, beside, labels, phase)});
  }
  int best_n = 0, second = 0;
  const std::optional<Choice> best =
      phase ? choose_with_phase(by_o, *phase) : choose_free(by_o, best_n, second);
  if (!best || best->s.total() < min_readings) {
    int credible = 0;
    for (const auto& r : *read) credible += !r.empty();
    note += credible == 0 ? fmt::format("no printed number read ({} candidate boxes)", boxes.size())
           : best        ? fmt::format("{} printed number(s) read, of which {} fit the arrangement, fewer than the {} "
                                       "needed here",
                                       credible, best->s.total(), min_readings)
           : phase       ? fmt::format("{} printed number(s) read, but no group number fits the arrangement clearly "
                                       "better than another",
                                       credible)
                         : fmt::format("{} printed number(s) read, but they do not fix the group (the best "
                                       "reading explains {}, the next {})",
                                       credible, best_n, second);
    return false;
  }
  D.largest_index = best->k;
  const int g = floor_div6(best->k), e = best->k - 6 * g + 1;
  note = fmt::format("{} element and {} group number(s) of {} read (text {}) fit the largest element found being "
                     "group {} element {}",
                     best->s.element, best->s.group, best->labels_read, to_string(best->o), g, e);
  return true;
}

// The detection as seen `levels` octaves down a Gaussian pyramid (`kept`
// and `partial` scaled with it).
ChartDetection halved(const ChartDetection& D, std::vector<ChartElement>& kept, std::vector<ChartElement>& partial,
                      int levels) {
  const double f = std::exp2(-levels);
  auto to_small = [&](Vec2 p) { return from_octave(p, -levels); };
  ChartDetection S = D;
  S.fibre_lattice_pitch_px *= f;
  for (ChartElement& e : S.elements) e.period_px *= f;
  for (BarPattern& p : S.patterns) {
    p.center_px = to_small(p.center_px);
    p.period_px *= f;
    p.bar_length_px *= f;
    for (Vec2& b : p.bar_centers_px) b = to_small(b);
  }
  for (ChartElement& e : kept) e.period_px *= f;
  for (ChartElement& e : partial) e.period_px *= f;
  return S;
}

}  // namespace

// A fibre bundle (dev_01, dev_02) lays a honeycomb of 5-6 px over the
// chart that breaks the ink into dots and the ground into a net, so that
// no number is found. A grey closing, then an opening, with a disc of
// radius a third of the finest bar's width removes dark, then light,
// detail narrower than the disc; a numeral's strokes, about as wide as a
// bar, pass. (A quarter left a mottle of a fifth of the honeycomb's
// contrast where the nearest fibre core lies beyond the disc, half the
// lattice's period away, and the 16-bit copy of dev_02 read no number.)
cv::Mat without_fine_texture(const cv::Mat& img, double bar_px) {
  const int radius = std::clamp(static_cast<int>(std::lround(bar_px / 3)), 1, 4);
  const cv::Mat disc = cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * radius + 1, 2 * radius + 1});
  cv::Mat out;
  cv::morphologyEx(img, out, cv::MORPH_CLOSE, disc, {-1, -1}, 1, cv::BORDER_REPLICATE);
  cv::morphologyEx(out, out, cv::MORPH_OPEN, disc, {-1, -1}, 1, cv::BORDER_REPLICATE);
  return out;
}

// Numbers several times larger than OCR needs (a single element filling a
// 4K frame: bars 280 px wide) are read octaves down a Gaussian pyramid,
// where the finest element's bars are still >= 12 px wide (a number is
// 2-4 bar widths tall, and shorter than kMinLabelCharPx is no evidence): finding and
// reading label boxes costs in proportion to their area (3.9 s of dev_07's
// 5.5 s detection, full size), and the reader scales every patch to a
// 36 px character anyway.
bool anchor_by_printed_numbers(ChartDetection& D, const std::vector<ChartElement>& kept,
                               const std::vector<ChartElement>& partial, const cv::Mat& img,
                               std::optional<int> phase, std::string& note, NumberImages& images) {
  CV_Assert(!images.source_data || img.data == images.source_data);
  if (!images.source_data) {
    images.bar_px = 1e300;
    for (const ChartElement& e : kept) images.bar_px = std::min(images.bar_px, 0.5 * e.period_px);
    while (images.bar_px * 0.5 >= 12 && std::min(img.cols, img.rows) >> (images.levels + 1) >= 64)
      ++images.levels, images.bar_px *= 0.5;
    const auto at_level = [&](cv::Mat m) {
      for (int l = 0; l < images.levels; ++l) cv::pyrDown(m, m);
      return m;
    };
    const auto smoothed = [&](double pitches) {  // its own buffer: `img` is the caller's
      cv::Mat out;
      cv::GaussianBlur(img, out, {0, 0}, pitches * D.fibre_lattice_pitch_px);
      return out;
    };
    // Under a fibre bundle `img` is smoothed at kLatticeSmoothingPitches
    // already (detect_chart); the numbers are read smoothed a little more,
    // where a 6's counter opens, and must read alike smoothed more again
    // (below).
    const bool lattice = D.fibre_lattice_pitch_px > 0;
    images.small.img = at_level(lattice ? smoothed(kNumberSmoothingPitches) : img);
    if (lattice) images.check.img = at_level(smoothed(kCheckSmoothingPitches));
    images.source_data = img.data;
  }
  std::vector<ChartElement> kept_small = kept, partial_small = partial;
  ChartDetection S = images.levels == 0 ? D : halved(D, kept_small, partial_small, images.levels);
  bool anchored = anchor_at_scale(S, kept_small, partial_small, images.small, phase, note);
  // Under a fibre bundle's honeycomb a 6 and an 8 differ by a counter the
  // lattice half fills: how much smoothing opens it decides the reading
  // (dev_01's 8-bit frame read its group number 6 as an 8, all two groups
  // high, when the lattice's pitch moved by 1 %). The anchor stands only
  // where the numbers read alike on two smoothings, cleaned or not.
  const auto read_alike = [&](NumberSite& check, int min_readings, std::string& anchor_note) {
    if (images.check.img.empty()) return true;
    ChartDetection C = S;
    std::string check_note;
    if (anchor_at_scale(C, kept_small, partial_small, check, phase, check_note, min_readings) &&
        C.largest_index == S.largest_index)
      return true;
    anchor_note = fmt::format("under the fibre bundle's honeycomb the printed numbers do not read alike smoothed "
                              "a little more ({}; then {})",
                              anchor_note, check_note);
    return false;
  };
  if (anchored && !read_alike(images.check, 1, note)) return false;
  // Only with the phase known: the numbers are then read upright as the
  // arrangement turns them, and a group number must fit the group's
  // parity. Read in the eight axis turns instead, a cleaned 20-degree
  // tilted fibre frame gave three numbers that fit a group too many (the
  // 16-bit copy of dev_02). And three readings must fit, not one: a
  // cleaned digit is rounder, and a "6" reads as an "8" that fits the
  // parity two groups too high (dev_02's, cleaned a little more, alone;
  // one of 50 drawn honeycomb frames with one element number beside it).
  if (!anchored && phase) {
    if (images.cleaned.img.empty()) images.cleaned.img = without_fine_texture(images.small.img, images.bar_px);
    std::string smooth_note;
    anchored = anchor_at_scale(S, kept_small, partial_small, images.cleaned, phase, smooth_note, 3);
    if (anchored) note = "with texture finer than the strokes removed, " + smooth_note;
    if (anchored && !images.check.img.empty()) {
      if (images.cleaned_check.img.empty())
        images.cleaned_check.img = without_fine_texture(images.check.img, images.bar_px);
      if (!read_alike(images.cleaned_check, 3, note)) return false;  // D keeps its relative index
    }
  }
  D.largest_index = S.largest_index;
  return anchored;
}

}  // namespace tactres::locate_detail
