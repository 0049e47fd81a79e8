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
#include <map>
#include <memory>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "chart_detect_internal.h"
#include "tactres/labels/label_boxes.h"
#include "tactres/labels/label_reader.h"

namespace tactres::locate_detail {

namespace {

// Absolute indices the largest element found may have: groups -2..9.
constexpr int kMinIndex = -12, kMaxIndex = 59;
constexpr size_t kMaxBoxes = 40;

Vec2 box_center(const cv::Rect& b) { return {b.x + 0.5 * b.width, b.y + 0.5 * b.height}; }

Vec2 element_center(const ChartDetection& D, const ChartElement& e) {
  return 0.5 * (D.patterns[e.h].center_px + D.patterns[e.v].center_px);
}

// One reader per thread: Tesseract's initialisation costs tens of ms.
LabelReader* thread_reader(std::string& error) {
  thread_local LabelReaderOrError made = LabelReader::create();
  error = made.error;
  return made.reader.get();
}

struct Label {
  Vec2 center_px;
  int value = 0;
  double char_height_px = 0;
};

// The boxes that may hold numbers, within the elements' extent (grown by a
// few bar lengths: the labels sit beside and above the elements), the
// kMaxBoxes nearest to an element.
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
  // once per box, not per comparison.
  std::vector<std::pair<double, cv::Rect>> by_distance;
  for (const cv::Rect& b : boxes) {
    const Vec2 c = box_center(b);
    double nearest = 1e300;
    for (const ChartElement& e : kept) nearest = std::min(nearest, norm(c - element_center(D, e)) / e.period_px);
    by_distance.push_back({nearest, b});
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

// For each candidate k, how many labels it explains (each label once). On
// MIL-STD-150A charts an element's number stands beside it, about one
// period (two bar widths) tall; a group's number stands above its column,
// one to three periods of the group's first element tall. A label is read
// as either, only where its size and place allow it.
std::map<int, int> support(const ChartDetection& D, const std::vector<ChartElement>& kept, const std::vector<Label>& labels) {
  std::map<int, int> votes;
  for (const Label& l : labels) {
    const ChartElement* nearest = nullptr;
    double best = 1e300;
    for (const ChartElement& e : kept) {
      const double d = norm(l.center_px - element_center(D, e)) / e.period_px;
      if (d < best) best = d, nearest = &e;
    }
    if (!nearest || best > 8) continue;
    const double size = l.char_height_px / nearest->period_px;
    const bool as_element = l.value >= 1 && l.value <= 6 && size > 0.5 && size < 2.2 && best < 5;
    const bool as_group = size > 1.0 && size < 3.5;
    for (int k = kMinIndex; k <= kMaxIndex; ++k) {
      const int n = nearest->relative_index + k;
      const bool fits = (as_element && n - 6 * floor_div6(n) == l.value - 1) || (as_group && floor_div6(n) == l.value);
      votes[k] += fits;
    }
  }
  return votes;
}

}  // namespace

bool anchor_by_printed_numbers(ChartDetection& D, const std::vector<ChartElement>& kept, const cv::Mat& img,
                               std::string& note) {
  std::string error;
  LabelReader* reader = thread_reader(error);
  if (!reader) {
    note = "the printed numbers cannot be read: " + error;
    return false;
  }
  const std::vector<cv::Rect> boxes = label_boxes(img, D, kept);
  const auto read = read_boxes(*reader, img, boxes, D.light_bars ? Ink::light : Ink::dark);
  // The orientation and k together: in the wrong orientation the numbers
  // (a 6 read as 9, a 2 as 5) do not fit the elements' order.
  int best_k = 0, best = 0, second = 0, labels_read = 0;
  LabelOrientation best_o;
  for (const LabelOrientation& o : all_label_orientations()) {
    const std::vector<Label> labels = labels_in(boxes, read, o);
    for (const auto& [k, n] : support(D, kept, labels)) {
      if (n > best) {
        second = best, best = n, best_k = k, best_o = o;
        labels_read = static_cast<int>(labels.size());
      } else if (n > second) {
        second = n;
      }
    }
  }
  // A clear winner only: a wrong absolute group is worse than a relative one.
  if (best < 3 || best < second + 2) {
    int credible = 0;
    for (const auto& r : read) credible += !r.empty();
    note = credible == 0 ? fmt::format("no printed number read ({} candidate boxes)", boxes.size())
                         : fmt::format("{} printed number(s) read, but they do not fix the group (the best "
                                       "reading explains {}, the next {})",
                                       credible, best, second);
    return false;
  }
  D.largest_index = best_k;
  note = fmt::format("{} of {} printed numbers read (text {}) fit the largest element found being group {} element {}",
                     best, labels_read, to_string(best_o), floor_div6(best_k), best_k - 6 * floor_div6(best_k) + 1);
  return true;
}

}  // namespace tactres::locate_detail
