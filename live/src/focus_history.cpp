#include "tactres/live/focus_history.h"

#include <algorithm>
#include <array>

namespace tactres {

FocusReading focus_reading(const Measurement& m, BarOrientation o, const FocusElement& focus) {
  FocusReading r;
  const Limit& limit = o == BarOrientation::horizontal_bars ? m.horizontal : m.vertical;
  if (focus.group && focus.element) {
    r.group = *focus.group;
    r.element = *focus.element;
  } else if (limit.any_resolved) {
    r.group = limit.group;
    r.element = limit.element;
  } else {
    return r;
  }
  for (const ElementResult& e : m.elements)
    if (e.orientation == o && e.group == r.group && e.element == r.element) {
      r.present = e.status == ElementStatus::ok;
      r.status = e.status;
      r.m = e.m;
      r.m_sigma = e.m_sigma;
    }
  return r;
}

std::optional<double> focus_score(const Measurement& m) {
  if (!m.usable) return std::nullopt;
  auto value = [](const Limit& l) { return l.any_resolved ? l.interpolated_lp_per_mm.value_or(l.lp_per_mm) : 0.0; };
  return 0.5 * (value(m.horizontal) + value(m.vertical));
}

void FocusHistory::push(std::optional<double> value, long frame) {
  values_.push_back(value);
  while (values_.size() > capacity_) values_.pop_front();
  if (value && (!best_ || *value > *best_)) {
    best_ = value;
    best_frame_ = frame;
  }
}

std::string FocusHistory::sparkline() const {
  static const std::array<const char*, 8> kBlocks = {"\u2581", "\u2582", "\u2583", "\u2584",
                                                     "\u2585", "\u2586", "\u2587", "\u2588"};
  double lo = 0, hi = 0;
  bool any = false;
  for (const auto& v : values_)
    if (v) {
      lo = any ? std::min(lo, *v) : *v;
      hi = any ? std::max(hi, *v) : *v;
      any = true;
    }
  std::string s;
  for (const auto& v : values_) {
    if (!v) {
      s += ' ';
      continue;
    }
    const int k = hi > lo ? std::clamp(int((*v - lo) / (hi - lo) * 7.999), 0, 7) : 3;
    s += kBlocks[k];
  }
  return s;
}

}  // namespace tactres
