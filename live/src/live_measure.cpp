#include "tactres/live/live_measure.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "tactres/measure/element_grading.h"

namespace tactres {

void LiveOptions::validate() const {
  measure.validate();
  if (refit_every < 1 || refit_every > 100000)
    throw std::invalid_argument(fmt::format("--refit-every {}: must be in [1, 100000] frames", refit_every));
  if (!(light_change > 0 && light_change <= 1))
    throw std::invalid_argument(fmt::format("--light-change {}: must be in (0, 1]", light_change));
  if (near_limit_span < 1 || near_limit_span > 30)
    throw std::invalid_argument(fmt::format("near-limit span {}: must be in [1, 30] elements", near_limit_span));
}

double frame_level(const cv::Mat& luminance) {
  double sum = 0;
  long n = 0;
  for (int y = 0; y < luminance.rows; y += 8) {
    const float* row = luminance.ptr<float>(y);
    for (int x = 0; x < luminance.cols; x += 8)
      if (std::isfinite(row[x])) {
        sum += row[x];
        ++n;
      }
  }
  return n > 0 ? sum / n : 0;
}

std::string limit_label(const LiveFrameResult& r, BarOrientation o) {
  if (!r.measured) return "-";
  const Limit& l = r.measurement.parts(o).reported();
  if (!l.any_resolved) return "none resolved";
  return fmt::format("G{}E{} {:.2f}{}", l.group, l.element, l.interpolated_lp_per_mm.value_or(l.lp_per_mm),
                     r.relative ? "x" : " lp/mm");
}

double elements_from_limit(double lp_per_mm, const Limit& limit, double coarsest_lp_per_mm) {
  const double at = limit.any_resolved ? limit.lp_per_mm : coarsest_lp_per_mm;
  return 6 * std::log2(lp_per_mm / at);
}

LiveMeasurer::LiveMeasurer(const LiveOptions& options, const TargetLayout* layout, const CameraModel* camera)
    : options_(options), layout_(layout), camera_(camera) {
  options_.validate();
  if (!options_.chart && !layout_) throw std::invalid_argument("layout mode needs a layout");
}

LiveFrameResult LiveMeasurer::measure(const Frame& frame) {
  LiveFrameResult r;
  if (frame.image) {
    const double level = frame_level(frame.image->luminance);
    const bool light_changed =
        level_at_refit_ > 0 && std::abs(level / level_at_refit_ - 1) > options_.light_change;
    const bool refit = !options_.tracking || frames_since_refit_ >= options_.refit_every || light_changed;
    const auto t0 = std::chrono::steady_clock::now();
    try {
      r = options_.chart ? measure_chart_frame(*frame.image, refit) : measure_layout(*frame.image, refit);
    } catch (const std::exception& e) {
      // A frame the analysis refuses outright (another size than the
      // camera model's) is a row with its problem; the sequence goes on.
      r = LiveFrameResult{};
      r.problem = e.what();
    }
    r.analysis_ms = 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (r.refit) {
      frames_since_refit_ = 0;
      level_at_refit_ = level;
    }
    ++frames_since_refit_;
  } else {
    r.problem = frame.problem;
  }
  r.index = frame.index;
  r.name = frame.name;
  r.time_s = frame.time_s;
  if (!r.measured) {  // a frame without the target: the next one starts afresh
    track_.reset();
    chart_track_.reset();
    last_elements_.clear();
  }
  return r;
}

void LiveMeasurer::always_fit(BarOrientation o, int group, int element) {
  (o == BarOrientation::horizontal_bars ? always_h_ : always_v_) = std::pair(group, element);
}

bool LiveMeasurer::fit_near_limit(int group, int element, double lp_per_mm, BarOrientation o,
                                  double coarsest_lp_per_mm) const {
  const bool h = o == BarOrientation::horizontal_bars;
  const std::optional<std::pair<int, int>>& always = h ? always_h_ : always_v_;
  if (always && always->first == group && always->second == element) return true;
  return std::abs(elements_from_limit(lp_per_mm, h ? last_h_ : last_v_, coarsest_lp_per_mm)) <=
         options_.near_limit_span + 0.01;
}

FramePlan LiveMeasurer::plan_for(bool refit) const {
  FramePlan plan;
  if (!options_.tracking || !track_) return plan;
  plan.track = &*track_;
  plan.reuse_reference = !refit;
  if (options_.elements == LiveElements::near_limit && !refit &&
      last_elements_.size() == layout_->elements.size()) {
    const double coarsest = layout_->elements.front().lp_per_mm;
    plan.carried = &last_elements_;
    plan.fit_element = [this, coarsest](size_t i) {
      const ElementLayout& e = layout_->elements[i];
      return fit_near_limit(e.group, e.element, e.lp_per_mm, e.orientation, coarsest);
    };
  }
  return plan;
}

LiveFrameResult LiveMeasurer::measure_layout(const LoadedImage& image, bool refit) {
  LiveFrameResult r;
  FramePlan plan = plan_for(refit);
  FrameResult f = measure_frame(image, *layout_, camera_, options_.measure, plan);
  if (!f.measurement.usable && plan.track) {
    // What the frames before established may no longer hold (the target
    // moved far, the light changed): measure this frame from scratch.
    f = measure_frame(image, *layout_, camera_, options_.measure, {});
  }
  r.measured = f.measurement.usable;
  r.problem = f.measurement.problem;
  r.tracked = f.tracked;
  r.refit = f.reference_refit;
  r.measurement = std::move(f.measurement);
  if (r.measured) {
    track_ = std::move(f.track);
    last_elements_ = r.measurement.elements;  // all elements in layout order, carried ones included
    last_h_ = r.measurement.horizontal;
    last_v_ = r.measurement.vertical;
  }
  return r;
}

ChartFramePlan LiveMeasurer::chart_plan_for(bool refit) const {
  ChartFramePlan plan;
  if (!options_.tracking || !chart_track_ || refit) return plan;
  plan.track = &*chart_track_;
  if (options_.elements == LiveElements::near_limit && !chart_track_->elements.empty()) {
    const double coarsest = chart_track_->elements.front().lp_per_mm;
    plan.fit_element = [this, coarsest](const ElementResult& e) {
      return fit_near_limit(e.group, e.element, e.lp_per_mm, e.orientation, coarsest);
    };
  }
  return plan;
}

LiveFrameResult LiveMeasurer::measure_chart_frame(const LoadedImage& image, bool refit) {
  LiveFrameResult r;
  ChartMeasureOptions co;
  co.measure = options_.measure;
  co.detect = options_.chart_detect;
  const ChartFramePlan plan = chart_plan_for(refit);
  ChartFrameResult f = tactres::measure_chart_frame(image, co, plan);
  if (!f.measurement.measurement.usable && plan.track) {
    // The chart moved too far to follow, or the carried frame shows
    // nothing resolved: detect and measure this frame from scratch.
    f = tactres::measure_chart_frame(image, co, {});
  }
  Measurement& M = f.measurement.measurement;
  r.measured = M.usable;
  r.problem = M.problem;
  r.tracked = f.tracked;
  r.refit = !f.tracked;
  r.relative = f.measurement.detection.anchor == ChartAnchor::none;
  if (r.measured) {
    chart_track_ = std::move(f.track);
    last_h_ = M.horizontal;
    last_v_ = M.vertical;
  }
  r.measurement = std::move(M);
  return r;
}

}  // namespace tactres
