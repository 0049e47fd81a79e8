#include <doctest/doctest.h>

#include "tactres/live/focus_history.h"
#include "tactres/live/live_measure.h"

using namespace tactres;

TEST_CASE("focus history: the sparkline scales between min and max, gaps stay gaps, the best is kept") {
  FocusHistory h(4);
  h.push(0.1, 0);
  h.push(0.5, 1);
  h.push(std::nullopt, 2);
  h.push(0.3, 3);
  CHECK(h.sparkline() == "\u2581\u2588 \u2584");
  CHECK(h.best() == doctest::Approx(0.5));
  CHECK(h.best_frame() == 1);
  h.push(0.2, 4);  // the oldest reading leaves the window; the best stays
  CHECK(h.sparkline() == "\u2588 \u2583\u2581");
  CHECK(h.best_frame() == 1);
  h.push(0.9, 5);
  CHECK(h.best_frame() == 5);
}

TEST_CASE("focus reading: the limit element by default, a fixed element when given") {
  Measurement m;
  m.usable = true;
  m.horizontal.any_resolved = true;
  m.horizontal.group = 2;
  m.horizontal.element = 3;
  m.horizontal.lp_per_mm = 5.04;
  ElementResult a = ElementResult::of(2, 3, BarOrientation::horizontal_bars, 5.04, 4);
  a.status = ElementStatus::ok;
  a.m = 0.2;
  ElementResult b = ElementResult::of(1, 1, BarOrientation::horizontal_bars, 2.0, 9);
  b.status = ElementStatus::ok;
  b.m = 0.8;
  m.elements = {b, a};
  FocusReading r = focus_reading(m, BarOrientation::horizontal_bars, {});
  CHECK(r.present);
  CHECK(r.group == 2);
  CHECK(r.m == doctest::Approx(0.2));
  r = focus_reading(m, BarOrientation::horizontal_bars, {1, 1});
  CHECK(r.m == doctest::Approx(0.8));
  // Nothing resolved vertically: no element to watch.
  CHECK_FALSE(focus_reading(m, BarOrientation::vertical_bars, {}).present);
  // The score averages the two orientations' limits (0 where none).
  CHECK(*focus_score(m) == doctest::Approx(0.5 * 5.04));
  m.usable = false;
  CHECK_FALSE(focus_score(m));
}

TEST_CASE("near-limit elements: counted in sixths of an octave from the limit") {
  Limit l;
  l.any_resolved = true;
  l.lp_per_mm = 4.0;
  CHECK(elements_from_limit(8.0, l, 1.0) == doctest::Approx(6));
  CHECK(elements_from_limit(4.0 / std::pow(2.0, 0.5), l, 1.0) == doctest::Approx(-3));
  l.any_resolved = false;  // from the coarsest element instead
  CHECK(elements_from_limit(2.0, l, 1.0) == doctest::Approx(6));
}

TEST_CASE("live options name the bad value") {
  LiveOptions o;
  o.refit_every = 0;
  CHECK_THROWS_WITH_AS(o.validate(), doctest::Contains("--refit-every"), std::invalid_argument);
  o.refit_every = 10;
  o.light_change = 0;
  CHECK_THROWS_WITH_AS(o.validate(), doctest::Contains("--light-change"), std::invalid_argument);
}

TEST_CASE("frame level: the mean of finite pixels, NaN skipped") {
  cv::Mat m(64, 64, CV_32F, cv::Scalar(0.25));
  m.at<float>(0, 0) = std::numeric_limits<float>::quiet_NaN();
  CHECK(frame_level(m) == doctest::Approx(0.25));
}
