// detect_chart (chart_detect.h): the elements found (chart_bars.cpp)
// indexed along the 2^(1/6) series under the image's scale field, anchored,
// and completed by the elements the columns predict and the lone patterns.

#include "tactres/locate/chart_detect.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "chart_detect_internal.h"
#include "finite_pixels.h"
#include "tactres/targets/usaf_series.h"

namespace tactres {

void ChartDetectOptions::validate() const {
  if (largest_group && (*largest_group < -10 || *largest_group > 12))
    throw std::invalid_argument(fmt::format("--largest-group must be in -10..12, got {}", *largest_group));
  if (largest_element < 1 || largest_element > 6)
    throw std::invalid_argument(fmt::format("--largest-element must be in 1..6, got {}", largest_element));
  if (px_per_mm && !(std::isfinite(*px_per_mm) && *px_per_mm > 0 && *px_per_mm <= 1e5))
    throw std::invalid_argument(fmt::format("--px-per-mm must be in (0, 100000], got {}", *px_per_mm));
  if (largest_group && px_per_mm)
    throw std::invalid_argument("give one anchor: --largest-group or --px-per-mm, not both");
  if (!(min_bar_px >= 0.5 && min_bar_px <= 20))
    throw std::invalid_argument("the minimum bar width must be in [0.5, 20] px");
}

const char* to_string(ChartAnchor a) {
  switch (a) {
    case ChartAnchor::none: return "none";
    case ChartAnchor::largest_group: return "largest_group";
    case ChartAnchor::px_per_mm: return "px_per_mm";
    case ChartAnchor::arrangement: return "arrangement";
    case ChartAnchor::printed_numbers: return "printed_numbers";
  }
  return "none";
}

namespace locate_detail {

Vec2 ScaleField::position(const ChartDetection& D, const ChartElement& e) const {
  return position(0.5 * (D.patterns[e.h].center_px + D.patterns[e.v].center_px));
}

double ScaleField::bar_px(const ChartDetection& D, const ChartElement& e) const {
  return 0.5 * std::exp(level0 + dot(g, position(D, e)) - e.relative_index * std::log(2.0) / 6);
}

}  // namespace locate_detail

using namespace locate_detail;

namespace {

// The luminance with NaN (masked) pixels set to the median, so that they
// make no edges (a copy; the luminance itself when every pixel is finite,
// as in most captures); nullopt if no pixel is finite.
std::optional<cv::Mat> with_finite_pixels(const cv::Mat& luminance) {
  if (all_finite(luminance)) return luminance;
  cv::Mat img = luminance.clone();
  std::vector<float> finite;
  for (int y = 0; y < img.rows; y += 3)
    for (int x = 0; x < img.cols; x += 3)
      if (std::isfinite(img.at<float>(y, x))) finite.push_back(img.at<float>(y, x));
  if (finite.empty()) return std::nullopt;
  std::nth_element(finite.begin(), finite.begin() + finite.size() / 2, finite.end());
  const float median = finite[finite.size() / 2];
  img.forEach<float>([&](float& v, const int*) {
    if (!std::isfinite(v)) v = median;
  });
  return img;
}

// Every element of a chart has the same layout: the H-to-V separation in
// periods is one number (3.5 on the generated chart). A pair far from the
// chart's median is two patterns of different elements, and is dropped.
// Returns the separation (the median, or 3.5 with fewer than 3 elements).
double drop_odd_separations(const ChartDetection& D, std::vector<ChartElement>& elements) {
  double separation_periods = 3.5;  // H-to-V centre distance in periods: the chart's median
  if (elements.size() >= 3) {
    auto separation = [&](const ChartElement& e) {
      return norm(D.patterns[e.v].center_px - D.patterns[e.h].center_px) / e.period_px;
    };
    std::vector<double> seps;
    for (const ChartElement& e : elements) seps.push_back(separation(e));
    std::nth_element(seps.begin(), seps.begin() + seps.size() / 2, seps.end());
    const double median = seps[seps.size() / 2];
    separation_periods = median;
    std::erase_if(elements, [&](const ChartElement& e) { return std::abs(separation(e) / median - 1) > 0.12; });
  }
  return separation_periods;
}

// Relative indices: 6 log2(period ratio) steps from the largest.
// - Perspective makes the image scale vary over the chart, so the periods
//   are first divided by a scale field ln s = c1 x + c2 y (scale_gradient).
// - Blur widens the outer bars of a fine pattern in the binarised image
//   and so overstates its period; the order of the corrected periods
//   survives, and no (group, element) appears twice on a chart, so the
//   indices must rise strictly in that order.
// - The rounding offset comes from the well-sampled elements (>= 8 px
//   per period), whose periods the binarisation gets right.
//
// What the indexing needs of each element, computed once: the gradient
// search indexes the elements about 900 times.
struct IndexSample {
  double ln_period = 0;  // ln px
  Vec2 position;         // ScaleField::position
  bool well_sampled = false;
};

std::vector<IndexSample> index_samples(const ChartDetection& D, const std::vector<ChartElement>& elements,
                                       const ScaleField& field) {
  std::vector<IndexSample> s;
  for (const ChartElement& e : elements)
    s.push_back({std::log(e.period_px), field.position(D, e), e.period_px >= kWellSampledPeriodPx});
  return s;
}

// The indices for the field gradient g: `index[i]` for sample i, or -1
// for one far off the series (dropped); strictly rising in the order of the
// corrected periods, rounded with the offset of the well-sampled ones.
// Returns the misfit of the well-sampled ones (in steps^2).
double series_indices(const std::vector<IndexSample>& samples, Vec2 g, std::vector<int>& index) {
  std::vector<std::pair<double, size_t>> ln_corrected;
  ln_corrected.reserve(samples.size());
  for (size_t i = 0; i < samples.size(); ++i) ln_corrected.push_back({samples[i].ln_period - dot(g, samples[i].position), i});
  std::sort(ln_corrected.begin(), ln_corrected.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  // Steps of the series from the largest: 6 log2(p0 / corrected period).
  const double steps_per_ln = 6 / std::log(2.0), ln_p0 = ln_corrected.front().first;
  auto steps = [&](double ln_c) { return steps_per_ln * (ln_p0 - ln_c); };
  double offset = 0;
  int n_offset = 0;
  for (const auto& [ln_c, i] : ln_corrected)
    if (samples[i].well_sampled) {
      const double x = steps(ln_c);
      offset += x - std::round(x);
      ++n_offset;
    }
  if (n_offset > 0) offset /= n_offset;
  index.assign(samples.size(), -1);
  double sum = 0, sum2 = 0;
  int n = 0, last = 0;
  bool any = false;
  for (const auto& [ln_c, i] : ln_corrected) {
    const double x = steps(ln_c) - offset;
    int k = static_cast<int>(std::lround(x));
    if (any) k = std::max(k, last + 1);
    if (k - x > 1.6) continue;  // far off the series: not a chart element
    index[i] = k, last = k, any = true;
    if (samples[i].well_sampled) {  // misfit of the well-sampled ones, in steps
      const double r = k - x;
      sum += r, sum2 += r * r, ++n;
    }
  }
  return n > 1 ? sum2 / n - (sum / n) * (sum / n) + 1e-3 * norm(g) : 0.0;
}

// The elements indexed under the field gradient g, in the order of their
// corrected periods, into `out`; returns the misfit (series_indices).
double assign_indices(const ChartDetection& D, const std::vector<ChartElement>& elements, const ScaleField& field,
                      Vec2 g, std::vector<ChartElement>& out) {
  const std::vector<IndexSample> samples = index_samples(D, elements, field);
  std::vector<int> index;
  const double misfit = series_indices(samples, g, index);
  out.clear();
  for (size_t i = 0; i < elements.size(); ++i)
    if (index[i] >= 0) {
      out.push_back(elements[i]);
      out.back().relative_index = index[i];
    }
  sort_by_index(out);  // the order of the corrected periods: the indices rise strictly along it
  return misfit;
}

// Whether the elements lie along one line (a single column in view): the
// smaller spread of their centres under a fifth of the larger. Along a
// column the series itself shrinks the elements step by step, and a
// gradient along it trades that for another index spacing (the left half
// of dev_04, G4E2-E6, was indexed 0, 2, 4, 5, 6): no gradient is fitted.
// Two elements always lie on a line.
bool along_one_line(const ChartDetection& D, const std::vector<ChartElement>& elements) {
  if (elements.size() < 3) return true;
  cv::Mat centres(int(elements.size()), 2, CV_64F);
  for (size_t i = 0; i < elements.size(); ++i) {
    const Vec2 c = 0.5 * (D.patterns[elements[i].h].center_px + D.patterns[elements[i].v].center_px);
    centres.at<double>(int(i), 0) = c.x;
    centres.at<double>(int(i), 1) = c.y;
  }
  cv::Mat covariance, mean, variances;  // the variances along the principal axes, largest first
  cv::calcCovarMatrix(centres, covariance, mean, cv::COVAR_NORMAL | cv::COVAR_ROWS, CV_64F);
  cv::eigen(covariance, variances);
  return variances.at<double>(1) < 0.04 * variances.at<double>(0);  // spreads under 1 : 5
}

// The field's gradient: a grid search, then a finer one around the best;
// +-30 % scale change over half the image covers a 15-20 degree tilt of a
// chart that fills the view. A search, not a fit, because wrong indices
// make a fit converge to a wrong but self-consistent field. (A wide-angle
// camera 15 mm from a chart tilted by 20 degrees needs +-0.6: searched
// that far, a face-on view with a column cut by the image's edge found a
// spurious gradient far out and was indexed wrong; docs/CHART.md.)
Vec2 scale_gradient(const ChartDetection& D, const std::vector<ChartElement>& elements,
                    const ScaleField& field) {
  Vec2 best_g{0, 0};
  if (along_one_line(D, elements)) return best_g;
  const std::vector<IndexSample> samples = index_samples(D, elements, field);
  std::vector<int> index;
  const double cost0 = series_indices(samples, best_g, index);
  double best_cost = cost0;
  for (const double step : {0.03, 0.006}) {
    const Vec2 c = best_g;
    for (int i = -10; i <= 10; ++i)
      for (int j = -10; j <= 10; ++j) {
        const Vec2 g{c.x + i * step, c.y + j * step};
        const double cost = series_indices(samples, g, index);
        if (cost < best_cost - 1e-12) best_cost = cost, best_g = g;
      }
  }
  // A gradient must earn its place: with a dozen elements, some gradient
  // always rounds the noisy periods a little closer to integers, and a
  // spurious one can shift an index by one between elements far apart in
  // the image. A real tilt lowers the misfit many times over (15 degrees:
  // 0.26 -> 0.014); noise and blur-biased periods, by up to 2.7 times
  // (a 4.3 px defocus disc: 0.047 -> 0.0175, with a wrong index). A
  // gradient is kept when it lowers the misfit 4 times or more.
  if (!(best_cost < 0.25 * cost0)) best_g = {0, 0};
  return best_g;
}

// ln of an element's bar width, px, at relative index 0 and the image's
// centre, under the field: the same for every element that fits the series.
double series_level(const ChartDetection& D, const ScaleField& field, const ChartElement& e) {
  return std::log(e.period_px) + e.relative_index * std::log(2.0) / 6 - dot(field.g, field.position(D, e));
}

// A well-sampled element whose period does not fit its index under the
// field is a mismatch (more than 3/4 of a step off; blur overstates the
// binarised period of the finest of them by up to 2/3 of a step, e.g. a
// 4.3 px defocus disc on an 8 px period): dropped.
void drop_series_misfits(const ChartDetection& D, const ScaleField& field,
                         std::vector<ChartElement>& kept) {
  std::vector<double> levels;
  for (const ChartElement& e : kept)
    if (e.period_px >= kWellSampledPeriodPx) levels.push_back(series_level(D, field, e));
  if (levels.size() < 3) return;
  std::nth_element(levels.begin(), levels.begin() + levels.size() / 2, levels.end());
  const double c0 = levels[levels.size() / 2];
  std::erase_if(kept, [&](const ChartElement& e) {
    return e.period_px >= kWellSampledPeriodPx && std::abs(series_level(D, field, e) - c0) > 0.75 * std::log(2.0) / 6;
  });
}

// The series level of the elements (ScaleField::level0): the median over
// the well-sampled ones, or over all when none is.
double median_series_level(const ChartDetection& D, const ScaleField& field,
                           const std::vector<ChartElement>& kept) {
  std::vector<double> levels;
  for (const ChartElement& e : kept)
    if (e.period_px >= kWellSampledPeriodPx) levels.push_back(series_level(D, field, e));
  if (levels.empty())
    for (const ChartElement& e : kept) levels.push_back(series_level(D, field, e));
  std::nth_element(levels.begin(), levels.begin() + levels.size() / 2, levels.end());
  return levels[levels.size() / 2];
}

// The anchor from the arrangement (chart_detect.h): the index modulo 12 and
// the handedness from the elements' positions (D.elements), the group from
// the labels. `relative` says what unanchored indices mean.
// `ways`: the ways it fits when it fits in several (recognise_arrangement).
void anchor_by_arrangement(ChartDetection& D, const std::vector<ChartElement>& kept, const ScaleField& field,
                           const cv::Mat& img, const std::string& relative,
                           std::vector<ChartDetection::Arrangement>& ways) {
  recognise_arrangement(D, field, &ways);
  auto& A = D.arrangement;
  if (!A.recognised) {
    D.anchor_description = "none (" + A.note + "): " + relative;
    return;
  }
  std::optional<int> shift;  // in pairs of groups (12 indices)
  bool agree = true;
  // The seven-segment group labels are the generated chart's (glyphs.h);
  // other charts' numbers are read by OCR (anchor_by_printed_numbers).
  if (A.generated_style) {
    for (const ChartElement& e : kept) {
      const int n = e.relative_index + A.phase, n12 = n % 12;
      if (n12 != 1 && n12 != 6) continue;  // the tops of the columns, under the labels
      const int model_group = n / 6;
      const auto g = read_group_label(img, D, e, n12, model_group, field.bar_px(D, e));
      if (!g) continue;
      const int s = (*g - model_group) / 2;
      ++A.labels_read;
      if (shift && *shift != s) agree = false;
      shift = s;
    }
  }
  const std::string known = fmt::format(
      "the standard arrangement is recognised ({} of {} observations fit it: the side of each element's H triplet and the "
      "steps down the columns{}): it fixes each element's number and its group's parity",
      A.steps_matched, A.steps_checked, A.mirrored ? "; mirrored" : "");
  if (shift && agree) {
    D.largest_index = A.phase + 12 * *shift;
    D.anchor = ChartAnchor::arrangement;
    A.note = known + fmt::format(", and {} group label(s) read from the image fix the group", A.labels_read);
    D.anchor_description = "arrangement: " + A.note;
  } else {
    A.labels_read = shift ? A.labels_read : 0;
    A.note = known + (shift ? ", but the group labels read disagree"
                            : ", but none of the generated chart's seven-segment group labels was read, and nested "
                              "pairs repeat every 2 groups, so by itself it knows the group modulo 2 only");
    D.anchor_description = "none (" + A.note + "): " + relative;
  }
}

// The absolute index of relative index 0 from --px-per-mm or
// --largest-group, if given; `largest_period_px` is that element's period.
bool anchor_by_options(ChartDetection& D, double largest_period_px, const ChartDetectOptions& options) {
  if (options.px_per_mm) {
    // The largest element's frequency: px/mm over its period in px.
    const double lp_per_mm = *options.px_per_mm / largest_period_px;
    D.largest_index = static_cast<int>(std::lround(6 * std::log2(lp_per_mm)));
    D.anchor = ChartAnchor::px_per_mm;
    D.anchor_description = fmt::format(
        "--px-per-mm {:g}: the largest element found ({:.2f} px per line pair) is {:.3g} lp/mm", *options.px_per_mm,
        largest_period_px, lp_per_mm);
    return true;
  }
  if (options.largest_group) {
    D.largest_index = 6 * *options.largest_group + options.largest_element - 1;
    D.anchor = ChartAnchor::largest_group;
    D.anchor_description = fmt::format("--largest-group {}: the largest element found is group {} element {}",
                                       *options.largest_group, *options.largest_group, options.largest_element);
    return true;
  }
  return false;
}

// When the arrangement fits the elements found in several ways: the
// printed numbers read as each way has them stand and turn (upright, not
// mirrored). A way is chosen when the numbers fix the group under it and
// under no way with another index (a wrong way reads its numbers mirrored
// or where none stand, and a group number of the wrong parity fits none).
enum class WaysAnswer { chosen, none, contradictory };
WaysAnswer anchor_among_ways(ChartDetection& D, const std::vector<ChartElement>& kept,
                             const std::vector<ChartElement>& partial, const cv::Mat& img,
                             const std::vector<ChartDetection::Arrangement>& ways, std::string& note,
                             NumberImages& number_images) {
  std::optional<int> index;
  const ChartDetection::Arrangement* chosen = nullptr;
  std::string chosen_note;
  for (const ChartDetection::Arrangement& way : ways) {
    ChartDetection W = D;
    W.arrangement = way;
    std::string way_note;
    if (!anchor_by_printed_numbers(W, kept, partial, img, way.phase, way_note, number_images)) continue;
    if (index && *index != W.largest_index) {
      note = fmt::format("the arrangement fits the elements found in {} ways, and the printed numbers fix the group "
                         "under more than one of them, differently",
                         ways.size());
      return WaysAnswer::contradictory;
    }
    if (!index) index = W.largest_index, chosen = &way, chosen_note = way_note;
  }
  if (!index) {
    note = fmt::format("the arrangement fits the elements found in {} ways, and the printed numbers fix the group "
                       "under none of them",
                       ways.size());
    return WaysAnswer::none;
  }
  D.arrangement = *chosen;
  D.arrangement.note = fmt::format("the standard arrangement fits the elements found in {} ways about equally (this "
                                   "one: {} of {} observations{}); the printed numbers chose this one",
                                   ways.size(), chosen->steps_matched, chosen->steps_checked,
                                   chosen->mirrored ? ", mirrored" : "");
  D.largest_index = *index;
  D.anchor = ChartAnchor::printed_numbers;
  D.anchor_description = "printed numbers: " + D.arrangement.note + ": " + chosen_note;
  return WaysAnswer::chosen;
}

// The absolute index of relative index 0 (D.largest_index) from what the
// chart shows, the arrangement and its printed numbers, and what fixed it.
void anchor_from_chart(ChartDetection& D, const std::vector<ChartElement>& kept,
                       const std::vector<ChartElement>& partial, const ScaleField& field, const cv::Mat& img) {
  D.largest_index = 0;
  D.anchor = ChartAnchor::none;
  const std::string relative =
      "groups and elements are relative to the largest element found, which is called group 0 element 1, and "
      "lp/mm are relative to its frequency; give --largest-group or --px-per-mm for absolute values";
  D.elements = kept;
  std::vector<ChartDetection::Arrangement> ways;
  anchor_by_arrangement(D, kept, field, img, relative, ways);
  if (D.anchor != ChartAnchor::none) return;
  // Another typeface than the generator's: read the numbers by OCR.
  std::string note;
  std::string ways_note;
  NumberImages number_images;  // shared by every reading below
  if (!ways.empty()) {
    const WaysAnswer answer = anchor_among_ways(D, kept, partial, img, ways, ways_note, number_images);
    if (answer == WaysAnswer::chosen) return;
    // Numbers that fix the group differently under two ways contradict
    // each other; read without a phase they would not be more right.
    if (answer == WaysAnswer::contradictory) {
      D.anchor_description += "; printed numbers: " + ways_note;
      return;
    }
    ways_note += "; read without the arrangement, ";
  }
  const std::optional<int> phase =
      D.arrangement.recognised ? std::optional<int>(D.arrangement.phase) : std::nullopt;
  if (anchor_by_printed_numbers(D, kept, partial, img, phase, note, number_images)) {
    D.anchor = ChartAnchor::printed_numbers;
    D.anchor_description = "printed numbers: " + note;
  } else {
    D.anchor_description += "; printed numbers: " + ways_note + note;
  }
}

// The absolute index of relative index 0 (D.largest_index), from the
// options or else the chart itself, and what fixed it. An option the chart
// contradicts still stands, and ChartDetection::anchor_conflict says so.
void anchor(ChartDetection& D, const std::vector<ChartElement>& kept, const std::vector<ChartElement>& partial,
            const ScaleField& field, const ChartDetectOptions& options, const cv::Mat& img) {
  if (!anchor_by_options(D, kept.front().period_px, options)) {
    anchor_from_chart(D, kept, partial, field, img);
    return;
  }
  ChartDetection shown = D;
  anchor_from_chart(shown, kept, partial, field, img);
  if (shown.anchor == ChartAnchor::none || shown.largest_index == D.largest_index) return;
  const auto name = [](int n) {
    const UsafElement e = usaf_element_at(n);
    return fmt::format("G{}E{}", e.group, e.element);
  };
  D.anchor_conflict = fmt::format(
      "{} makes the largest element found {}, but the chart itself says {} ({}); the option was used: check it",
      options.px_per_mm ? "--px-per-mm" : "--largest-group", name(D.largest_index), name(shown.largest_index),
      shown.anchor_description);
}

// ChartDetection::single_pattern: the one large pattern of either polarity,
// if it is the only pattern of at least half its period; measured in the
// image's orientation, anchored only by the options.
bool single_pattern_element(ChartDetection& D, const PatternsFound& found, const ChartDetectOptions& options) {
  for (const bool light : {D.light_bars, !D.light_bars}) {
    const std::vector<BarPattern>& P = light ? found.light : found.dark;
    int best = -1;
    for (size_t k = 0; k < P.size(); ++k)
      if (best < 0 || P[k].period_px > P[best].period_px) best = static_cast<int>(k);
    if (best < 0 || P[best].period_px < 2 * ChartDetection::kSinglePatternMinBarPx) continue;
    bool alone = true;
    for (size_t k = 0; k < P.size(); ++k)
      alone = alone && (static_cast<int>(k) == best || P[k].period_px <= 0.5 * P[best].period_px);
    if (!alone) continue;
    D.light_bars = light;
    D.patterns = P;
    const BarPattern& p = P[best];
    ChartElement e;
    (std::abs(p.bar_dir.x) >= std::abs(p.bar_dir.y) ? e.h : e.v) = best;
    e.period_px = p.period_px;
    D.unpaired_patterns = static_cast<int>(P.size()) - 1;
    if (!anchor_by_options(D, p.period_px, options)) {
      D.largest_index = 0;
      D.anchor_description =
          "none (a single three-bar pattern: indices count from it, called G0E1; its orientation is the image's)";
    }
    e.group = floor_div6(D.largest_index);
    e.element = D.largest_index - 6 * e.group + 1;
    D.elements = {e};
    D.single_pattern = true;
    D.found = true;
    return true;
  }
  return false;
}

}  // namespace

ChartDetection detect_chart(const cv::Mat& luminance, const ChartDetectOptions& options) {
  options.validate();
  ChartDetection D;
  CV_Assert(luminance.type() == CV_32F);
  const std::optional<cv::Mat> finite = with_finite_pixels(luminance);
  if (!finite) {
    D.problem = "the image has no finite pixel";
    return D;
  }
  // Under a fibre bundle's honeycomb the cores cut every bar into dots at
  // full resolution and alias an octave down, and break the printed
  // numbers' strokes: the chart is found and its numbers read on a
  // smoothed copy (kLatticeSmoothingPitches: dev_01 1.8 px, dev_02 2.6
  // px), its bars held against the mottle left, not the pixel noise the
  // smoothing removed. There dev_01 shows G6E5, G6E6 and G7E1-E2, which
  // the image itself hides. The chart is measured on the image itself
  // (chart_measure.cpp).
  const std::optional<double> lattice_pitch_px = fibre_lattice_pitch_px(*finite);
  D.fibre_lattice_pitch_px = lattice_pitch_px.value_or(0);
  cv::Mat smoothed;
  if (lattice_pitch_px) cv::GaussianBlur(*finite, smoothed, {0, 0}, kLatticeSmoothingPitches * *lattice_pitch_px);
  const cv::Mat& img = lattice_pitch_px ? smoothed : *finite;
  const double contrast_sigmas = lattice_pitch_px ? kLatticeMottleSigmas : 0;
  // The image scale and the polarity that show more elements
  // (chart_detect_internal.h, ImageScale; a chart has one polarity).
  PatternsFound found = find_patterns(img, options.min_bar_px, ImageScale::linear, contrast_sigmas);
  Pairing ed = pair_patterns(found.dark), el = pair_patterns(found.light);
  {
    PatternsFound s = find_patterns(img, options.min_bar_px, ImageScale::stabilised, contrast_sigmas);
    Pairing sd = pair_patterns(s.dark), sl = pair_patterns(s.light);
    if (std::max(sd.elements.size(), sl.elements.size()) > std::max(ed.elements.size(), el.elements.size())) {
      found = std::move(s);
      ed = std::move(sd);
      el = std::move(sl);
    }
  }
  D.light_bars = el.elements.size() > ed.elements.size();
  D.patterns = D.light_bars ? found.light : found.dark;
  Pairing& pairing = D.light_bars ? el : ed;
  D.unpaired_patterns = pairing.unpaired;
  D.hv_period_ratio = std::exp(pairing.ln_hv_ratio);
  const bool none_paired = el.elements.empty() && ed.elements.empty();
  std::vector<ChartElement> elements = std::move(pairing.elements);
  D.separation_periods = drop_odd_separations(D, elements);
  if (elements.empty() && single_pattern_element(D, found, options)) return D;
  if (elements.empty()) {
    // No element of either polarity: the patterns of the one with more
    // say what is in view (a negative chart's are its light ones).
    if (none_paired && found.light.size() > found.dark.size()) {
      D.light_bars = true;
      D.patterns = found.light;
      D.unpaired_patterns = el.unpaired;
    }
    D.problem = no_element_problem(D.patterns);
    return D;
  }

  ScaleField field;
  field.cols = img.cols;
  field.rows = img.rows;
  // ln(scale) = g . (position - image centre) / half the image size.
  field.half = 0.5 * std::max(img.cols, img.rows);
  field.g = scale_gradient(D, elements, field);
  std::vector<ChartElement> kept;
  assign_indices(D, elements, field, field.g, kept);
  drop_series_misfits(D, field, kept);
  sort_by_index(kept);
  if (kept.empty()) {
    D.problem = "no USAF-1951 chart found: the elements found do not follow the 2^(1/6) series";
    return D;
  }
  const int min_index = kept.front().relative_index;
  for (ChartElement& e : kept) e.relative_index -= min_index;
  // Where the complete elements do not nest by themselves, the lone
  // patterns, indexed by the series as it stands, help place the nesting
  // (only there: a lone pattern's place is less sure than an element's,
  // and with dev_05's the point moved, and group 7's placed bars with it);
  // once it has moved an index, they are indexed again below.
  std::optional<Vec2> nesting_centre_px = fit_nesting(D, kept);
  if (!nesting_centre_px) {
    field.level0 = median_series_level(D, field, kept);
    D.elements = kept;
    nesting_centre_px = fit_nesting(D, kept, partial_elements(D, pairing.lone, field, img));
  }
  field.level0 = median_series_level(D, field, kept);

  // Partial elements are not anchored by themselves, but a group number may
  // stand by one (dev_03's "4" above its G4E1, whose H triplet the frame
  // cuts): the printed numbers are read beside them too.
  D.elements = kept;
  std::vector<ChartElement> partial = partial_elements(D, pairing.lone, field, img);
  anchor(D, kept, partial, field, options, img);
  for (ChartElement& e : kept) {
    const int n = D.largest_index + e.relative_index;
    e.group = floor_div6(n);
    e.element = n - 6 * e.group + 1;
  }
  D.elements = std::move(kept);
  // Column ends first: extrapolated from their neighbours, they are placed
  // better than by the nesting, which maps a coarse element from the
  // field's distorted corner to its centre (dev_04/05's G6E6).
  predict_column_ends(D);
  if (nesting_centre_px) predict_nested_pairs(D, *nesting_centre_px, img.cols, img.rows);
  number_partial_elements(D, std::move(partial), pairing.lone, img.cols, img.rows);
  D.found = true;
  return D;
}

}  // namespace tactres
