#pragma once
// What a person focusing a sensor watches (`tactres watch`): m(f) at one
// element per orientation, its recent history as a sparkline, the best
// value so far, and which frame was best overall.

#include <deque>
#include <optional>
#include <string>

#include "tactres/measure/measurement.h"

namespace tactres {

// The element watched per orientation: a fixed one (--focus-element G E),
// or the element at the current reported limit.
struct FocusElement {
  std::optional<int> group, element;  // both set: fixed
};

struct FocusReading {
  bool present = false;  // the element was measured on this frame
  int group = 0, element = 1;
  double m = 0, m_sigma = 0;
  ElementStatus status = ElementStatus::fit_failed;
};

FocusReading focus_reading(const Measurement& m, BarOrientation o, const FocusElement& focus);

// The value a frame is ranked by when looking for the best focus: the mean
// over both orientations of the reported limit (interpolated when there is
// one), lp/mm; nullopt for a frame without a usable measurement.
std::optional<double> focus_score(const Measurement& m);

// The last `capacity` readings of one number and its best so far.
class FocusHistory {
 public:
  explicit FocusHistory(size_t capacity = 40) : capacity_(capacity) {}
  // nullopt: no reading on this frame (shown as a gap).
  void push(std::optional<double> value, long frame);
  // One character per reading, U+2581..U+2588 scaled between the history's
  // minimum and maximum; a space for a gap.
  std::string sparkline() const;
  std::optional<double> best() const { return best_; }
  long best_frame() const { return best_frame_; }

 private:
  size_t capacity_;
  std::deque<std::optional<double>> values_;
  std::optional<double> best_;
  long best_frame_ = -1;
};

}  // namespace tactres
