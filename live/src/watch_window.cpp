#include "tactres/live/watch_window.h"

#include <cstdlib>
#include <stdexcept>

#include <fmt/format.h>
#include <opencv2/highgui.hpp>
#include <opencv2/imgproc.hpp>

#include "tactres/measure/overlay.h"

namespace tactres {

WatchWindow::WatchWindow(std::string title) : title_(std::move(title)) {
  auto set = [](const char* name) {
    const char* v = std::getenv(name);
    return v && *v;
  };
  // (OpenCV's GUI backend aborts the process when it cannot open one.)
  if (!set("DISPLAY") && !set("WAYLAND_DISPLAY"))
    throw std::runtime_error("--window needs a display (DISPLAY is not set): run without --window, or under X11/Wayland");
  cv::namedWindow(title_, cv::WINDOW_NORMAL | cv::WINDOW_KEEPRATIO);
}

WatchWindow::~WatchWindow() { cv::destroyWindow(title_); }

namespace {

// One text line and a bar whose length is m at the focus element.
void draw_orientation(cv::Mat& img, int row, const char* name, const LiveFrameResult& r, BarOrientation o,
                      const FocusReading& f) {
  const int y = 28 + 34 * row;
  std::string text = fmt::format("{} {}", name, limit_label(r, o));
  if (r.measured && f.present) text += fmt::format("   m(G{}E{}) {:.3f}", f.group, f.element, f.m);
  cv::putText(img, text, {10, y}, cv::FONT_HERSHEY_SIMPLEX, 0.7, {0, 0, 0}, 4, cv::LINE_AA);
  cv::putText(img, text, {10, y}, cv::FONT_HERSHEY_SIMPLEX, 0.7, {255, 255, 255}, 1, cv::LINE_AA);
  const int x0 = img.cols - 220, width = 200;
  cv::rectangle(img, {x0, y - 16}, {x0 + width, y + 2}, {255, 255, 255}, 1);
  if (f.present)
    cv::rectangle(img, {x0, y - 16}, {x0 + int(width * std::clamp(f.m, 0.0, 1.0)), y + 2}, {0, 200, 0}, cv::FILLED);
}

}  // namespace

bool WatchWindow::show(const cv::Mat& luminance, const LiveFrameResult& r, const FocusReading& h,
                       const FocusReading& v) {
  cv::Mat img = overlay_image(luminance, r.measurement);
  draw_orientation(img, 0, "H", r, BarOrientation::horizontal_bars, h);
  draw_orientation(img, 1, "V", r, BarOrientation::vertical_bars, v);
  if (!r.measured) cv::putText(img, r.problem.substr(0, 90), {10, 100}, cv::FONT_HERSHEY_SIMPLEX, 0.5, {0, 0, 255});
  cv::imshow(title_, img);
  const int key = cv::waitKey(1);
  const bool open = cv::getWindowProperty(title_, cv::WND_PROP_VISIBLE) >= 1;
  return open && key != 'q' && key != 27;
}

}  // namespace tactres
