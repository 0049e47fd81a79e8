#pragma once
// `tactres watch --window`: the frame with its measurement overlay, the
// limits and a focus bar per orientation, in an OpenCV window. Needs a
// display; nothing else in tactres does.

#include <string>

#include "tactres/live/focus_history.h"
#include "tactres/live/live_measure.h"

namespace tactres {

class WatchWindow {
 public:
  // Throws std::runtime_error when there is no display to open it on.
  explicit WatchWindow(std::string title);
  ~WatchWindow();
  // Shows the frame; false when the person closed the window or pressed q/Esc.
  bool show(const cv::Mat& luminance, const LiveFrameResult& r, const FocusReading& h, const FocusReading& v);

 private:
  std::string title_;
};

}  // namespace tactres
