// `tactres watch`: a live sequence measured frame by frame, for focusing
// and assembly (docs/LIVE.md).
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <map>
#include <memory>

#include <fmt/format.h>

#include "command.h"
#include "exit_codes.h"
#include "tactres/live/focus_history.h"
#include "tactres/live/frame_source.h"
#include "tactres/live/live_csv.h"
#include "tactres/live/live_measure.h"
#include "tactres/live/watch_window.h"
#include "tactres/targets/layout_json.h"
#include "tactres/util/atomic_file.h"

namespace tactres::cli {
namespace {

struct Args {
  std::string source, layout, camera, chart, csv;
  std::string preset = "fast", elements = "all", transfer = "auto";
  std::vector<int> focus_element;
  std::optional<int> largest_group;
  int largest_element = 1;
  std::optional<double> px_per_mm;
  double threshold = 0.10, detectability_k = 5.0;
  int refit_every = 30, channel = -1;
  double light_change = 0.05;
  bool no_tracking = false, window = false;
  long max_frames = 0;
  std::string size = "1280x720", fourcc = "MJPG";
  double fps = 30;
};

std::atomic<bool> g_stop{false};
extern "C" void on_interrupt(int) { g_stop = true; }

void add_watch_options(CLI::App& app, Args& a) {
  app.add_option("source", a.source,
                 "Frames: a folder of images or a quoted glob (read in name order), one image file, a video "
                 "file, or a V4L2 camera /dev/videoN")
      ->required();
  auto* layout = app.add_option("--layout", a.layout, "Layout JSON of the target (layout mode)");
  auto* chart = app.add_option("--chart", a.chart, "A standard USAF-1951 chart instead of a layout (docs/CHART.md)")
                    ->check(CLI::IsMember({"usaf1951"}))
                    ->excludes(layout);
  app.add_option("--camera", a.camera, "mrcal .cameramodel (layout mode; default: a pinhole fitted from the fiducials)")
      ->excludes(chart);
  auto* lg = app.add_option("--largest-group", a.largest_group, "Chart anchor: the largest element found is in this group (-10..12)")
                 ->needs(chart);
  app.add_option("--largest-element", a.largest_element, "With --largest-group: its element (1..6)")
      ->capture_default_str()
      ->check(CLI::Range(1, 6))
      ->needs(lg);
  app.add_option("--px-per-mm", a.px_per_mm, "Chart anchor: image scale at the chart, px/mm")->needs(chart)->excludes(lg);
  app.add_option("--preset", a.preset, "Accuracy/time trade: fast, balanced or precise")
      ->capture_default_str()
      ->check(CLI::IsMember({"fast", "balanced", "precise"}));
  app.add_option("--elements", a.elements,
                 "Fit all elements on every frame, or only those within 3 elements of the limit (near-limit; all "
                 "of them again on every refit)")
      ->capture_default_str()
      ->check(CLI::IsMember({"all", "near-limit"}));
  app.add_option("--focus-element", a.focus_element,
                 "Watch m(f) at group G element E (two numbers: a group of the target, E in 1..6; default: per orientation, the element at the limit on the first frame measured, kept for the whole run)")
      ->expected(2);
  app.add_option("--refit-every", a.refit_every,
                 "Fit the reference patch (chart: detect the chart) again every N frames, [1, 100000]")
      ->capture_default_str();
  app.add_option("--light-change", a.light_change,
                 "Refit as well when the frame's mean level changes by more than this fraction, (0, 1]")
      ->capture_default_str();
  app.add_flag("--no-tracking", a.no_tracking, "Measure every frame from scratch (no search near the last target)");
  app.add_option("--threshold", a.threshold, "Criterion: m(f) at the limit, in (0, 1)")
      ->capture_default_str()
      ->check(CLI::Range(0.001, 0.999));
  app.add_option("--detectability-k", a.detectability_k, "Rose threshold k, [1, 100]")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 100.0));
  app.add_option("--transfer", a.transfer,
                 "Code values to light: auto (tags; untagged 8-bit = sRGB, 16-bit and float = linear), linear, srgb, gamma:G (light = code^G, G in [0.2, 5])")
      ->capture_default_str();
  app.add_option("--channel", a.channel, "Channel to measure, -1..63 (default -1: Rec. 709 luminance)")->capture_default_str();
  app.add_option("--csv", a.csv, "One row per frame, written and flushed as it goes (docs/LIVE.md)");
  app.add_flag("--window", a.window, "Show the overlay, the numbers and a focus bar in a window (needs a display)");
  app.add_option("--max-frames", a.max_frames, "Stop after this many frames (0: at the end of the source or Ctrl-C)")
      ->capture_default_str()
      ->check(CLI::Range(0L, 1000000000L));
  app.add_option("--size", a.size, "Camera only: requested frame size WxH, px")->capture_default_str();
  app.add_option("--fps", a.fps, "Camera only: requested frame rate, frames/s")->capture_default_str();
  app.add_option("--fourcc", a.fourcc, "Camera only: requested pixel format (MJPG, YUYV, GREY...)")->capture_default_str();
}

LiveOptions live_options(const Args& a) {
  if (a.layout.empty() && a.chart.empty())
    throw std::invalid_argument("give the target: --layout layout.json, or --chart usaf1951");
  LiveOptions o;
  o.measure = MeasureOptions::for_preset(preset_from_string(a.preset));
  o.measure.criterion.threshold = a.threshold;
  o.measure.detectability.k = a.detectability_k;
  o.chart = !a.chart.empty();
  o.chart_detect.largest_group = a.largest_group;
  o.chart_detect.largest_element = a.largest_element;
  o.chart_detect.px_per_mm = a.px_per_mm;
  o.tracking = !a.no_tracking;
  o.refit_every = a.refit_every;
  o.light_change = a.light_change;
  o.elements = a.elements == "near-limit" ? LiveElements::near_limit : LiveElements::all;
  o.validate();
  return o;
}

CameraSettings camera_settings(const Args& a) {
  CameraSettings c;
  if (std::sscanf(a.size.c_str(), "%dx%d", &c.width_px, &c.height_px) != 2)
    throw std::invalid_argument("--size '" + a.size + "': give WxH, e.g. 1280x720");
  c.fps = a.fps;
  c.fourcc = a.fourcc;
  c.validate();
  return c;
}

// What the person at the terminal sees, one refreshing line per orientation.
struct StatusLines {
  bool tty = isatty(fileno(stderr));
  bool drawn = false;
  std::string last_problem;  // of the frame before, if it was unusable
  FocusHistory h{40}, v{40};

  void update(const LiveFrameResult& r, const FocusReading& fh, const FocusReading& fv) {
    h.push(fh.present ? std::optional<double>(fh.m) : std::nullopt, r.index);
    v.push(fv.present ? std::optional<double>(fv.m) : std::nullopt, r.index);
    if (!tty) return;
    if (drawn) fmt::print(stderr, "\033[2A");
    // A frame that could not be measured says why in full, on a line of its
    // own that stays above the two live ones; once per new problem, so that
    // a dead source does not scroll the terminal at its frame rate.
    if (!r.measured && r.problem != last_problem)
      fmt::print(stderr, "\r\033[Kframe {}: unusable: {}\n", r.index, r.problem);
    last_problem = r.measured ? std::string() : r.problem;
    print(r, "H", BarOrientation::horizontal_bars, fh, h);
    print(r, "V", BarOrientation::vertical_bars, fv, v);
    drawn = true;
  }

  static void print(const LiveFrameResult& r, const char* name, BarOrientation o, const FocusReading& f,
                    const FocusHistory& hist) {
    const std::string focus = f.present ? fmt::format("m(G{}E{}) {:.3f}", f.group, f.element, f.m) : "m -";
    const std::string best = hist.best() ? fmt::format("best {:.3f} @ {}", *hist.best(), hist.best_frame()) : "";
    fmt::print(stderr, "\r\033[K{} frame {:>5} {:>6.1f} ms  {:<28} {:<18} {} {}\n", name, r.index, r.analysis_ms,
               r.measured ? limit_label(r, o) : "unusable (said above)", focus, hist.sparkline(), best);
  }
};

void hold_limit_element(const Limit& limit, FocusElement& focus) {
  if (!focus.group && limit.any_resolved) focus = {limit.group, limit.element};
}

// The best frame: the highest focus_score, the first of equals.
struct Best {
  std::optional<double> score;
  LiveFrameResult frame;
};

int run_watch(const Args& a) {
  const LiveOptions options = live_options(a);
  std::optional<TargetLayout> layout;
  if (!options.chart) layout = read_layout_file(a.layout);
  std::optional<CameraModel> camera;
  if (!a.camera.empty()) camera = CameraModel::load(a.camera);
  LoadOptions load;
  load.channel = a.channel;
  load.transfer = transfer_from_option(a.transfer);
  load.upright = !layout;  // chart mode: H and V as a person sees the file
  FocusElement focus_h, focus_v;
  if (a.focus_element.size() == 2) {
    if (a.focus_element[1] < 1 || a.focus_element[1] > 6)
      throw std::invalid_argument("--focus-element G E: E must be in 1..6");
    if (layout && (a.focus_element[0] < layout->first_group || a.focus_element[0] > layout->last_group))
      throw std::invalid_argument(fmt::format("--focus-element G E: the target has groups {}..{}, not {}",
                                              layout->first_group, layout->last_group, a.focus_element[0]));
    focus_h = focus_v = {a.focus_element[0], a.focus_element[1]};
  }
  // The CSV over the source, the layout or the camera would destroy it.
  refuse_colliding_outputs({a.csv}, {a.source, a.layout, a.camera});
  std::unique_ptr<FrameSource> source = open_frame_source(a.source, load, camera_settings(a));
  std::unique_ptr<WatchWindow> window;
  if (a.window) window = std::make_unique<WatchWindow>("tactres watch");
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> csv(nullptr, &std::fclose);
  if (!a.csv.empty()) {
    csv.reset(std::fopen(a.csv.c_str(), "w"));
    if (!csv) throw std::runtime_error("cannot write " + a.csv);
    std::fputs(live_csv_header().c_str(), csv.get());
    std::fflush(csv.get());
  }
  LiveMeasurer measurer(options, layout ? &*layout : nullptr, camera ? &*camera : nullptr);
  std::signal(SIGINT, on_interrupt);
  fmt::print(stderr, "watching {} (Ctrl-C ends with a summary)\n", source->describe());

  StatusLines status;
  Best best;
  long frames = 0, measured = 0, tracked = 0;
  std::vector<double> ms;
  std::map<std::string, long> problems;  // of the frames not measured: what each said
  while (!g_stop && (a.max_frames == 0 || frames < a.max_frames)) {
    std::optional<Frame> frame = source->next();
    if (!frame) break;
    const LiveFrameResult r = measurer.measure(*frame);
    // Without --focus-element, each orientation watches the element at its
    // limit on the first frame measured, and keeps it: a history of m at
    // one element compares like with like while the focus changes.
    if (r.measured) {
      hold_limit_element(r.measurement.horizontal, focus_h);
      hold_limit_element(r.measurement.vertical, focus_v);
      if (focus_h.group) measurer.always_fit(BarOrientation::horizontal_bars, *focus_h.group, *focus_h.element);
      if (focus_v.group) measurer.always_fit(BarOrientation::vertical_bars, *focus_v.group, *focus_v.element);
    }
    const FocusReading fh = focus_reading(r.measurement, BarOrientation::horizontal_bars, focus_h);
    const FocusReading fv = focus_reading(r.measurement, BarOrientation::vertical_bars, focus_v);
    if (csv) {
      std::fputs(live_csv_row(r, fh, fv).c_str(), csv.get());
      std::fflush(csv.get());
    }
    status.update(r, fh, fv);
    if (window && frame->image && !window->show(frame->image->luminance, r, fh, fv)) g_stop = true;
    ++frames;
    if (!r.measured) ++problems[r.problem.empty() ? "no reason given" : r.problem];
    if (r.measured) {
      ++measured;
      tracked += r.tracked;
      ms.push_back(r.analysis_ms);
      const std::optional<double> score = focus_score(r.measurement);
      if (score && (!best.score || *score > *best.score)) best = {score, r};
    }
  }
  std::signal(SIGINT, SIG_DFL);

  std::sort(ms.begin(), ms.end());
  fmt::print("{} frame(s), {} measured ({} tracked), median analysis {:.1f} ms{}\n", frames, measured, tracked,
             ms.empty() ? 0.0 : ms[ms.size() / 2], g_stop ? "; stopped by the user" : "");
  if (!best.score) {
    // What most frames said, whether or not a CSV or a terminal showed it.
    const auto most = std::max_element(problems.begin(), problems.end(),
                                       [](const auto& x, const auto& y) { return x.second < y.second; });
    fmt::print(stderr, "no frame could be measured: {}{}\n",
               most == problems.end() ? "no frame was read" : most->first,
               most == problems.end() ? ""
               : problems.size() == 1 ? fmt::format(" ({} frame(s))", most->second)
                                      : fmt::format(" ({} of {} frame(s); {} other problem(s){})", most->second, frames,
                                                    problems.size() - 1, csv ? ": see the CSV's problem column" : ""));
    return kExitUnusableInput;
  }
  fmt::print("best frame: {} ({}): H {}; V {}\n", best.frame.index, best.frame.name,
             limit_label(best.frame, BarOrientation::horizontal_bars),
             limit_label(best.frame, BarOrientation::vertical_bars));
  return kExitOk;
}

}  // namespace

Command watch_command() {
  return {"watch", "Measure a live sequence (camera, video, image folder) frame by frame, for focusing and assembly",
          [](CLI::App& app) -> std::function<int()> {
            auto a = std::make_shared<Args>();
            add_watch_options(app, *a);
            return [a]() { return run_watch(*a); };
          }};
}

}  // namespace tactres::cli
