// End to end: simulated photographs of the standard USAF-1951 chart,
// measured with no layout and no fiducials, compared with the simulator's
// analytic truth (docs/CHART.md; helpers in measure_chart_support.h).
// This part: zoomed-in views of a few groups (down to a microscope) under
// Gaussian blur, a defocus disc or diffraction, with the true limit placed
// in a known group.
#include <doctest/doctest.h>

#include "measure_chart_support.h"

using namespace tactres;
using namespace tactres::testing;
using namespace tactres::chart_e2e;

TEST_CASE("chart: only groups 2-3 in view (zoomed in), limit in group 3, 40 dB noise") {
  TempDir dir("chart");
  ChartScene c;
  c.view = view_on(chart(), pair_center(chart(), 2), 110, 0);
  c.sensor = sensor_40db(3);
  ChartDetectOptions d;
  d.px_per_mm = 110;
  check_against_truth(render_and_measure(c, dir, "zoom23", d), "groups 2-3 at 110 px/mm", 4);
}

TEST_CASE("chart: only groups 4-5 in view (microscope), limit in group 5") {
  TempDir dir("chart");
  ChartScene c;
  c.view = view_on(chart(), pair_center(chart(), 4), 330, 0);
  ChartDetectOptions d;
  d.px_per_mm = 330;
  check_against_truth(render_and_measure(c, dir, "zoom45", d), "groups 4-5 at 330 px/mm", 4);
}

TEST_CASE("chart: defocus disc, groups 6-7 under a microscope, limit in group 6") {
  MilStdChartOptions o;
  o.first_group = 4;
  o.last_group = 7;
  static const TargetLayout fine = make_mil_std_chart(o);
  TempDir dir("chart");
  ChartScene c;
  c.layout = &fine;
  c.view = view_on(fine, pair_center(fine, 6), 700, 0);
  PsfOptions psf;
  psf.kind = PsfOptions::defocus_disc;
  psf.radius_px = 3.4;
  c.psf = psf;
  c.sensor = sensor_40db(21);
  ChartDetectOptions d;
  d.px_per_mm = 700;
  check_against_truth(render_and_measure(c, dir, "micro67", d), "groups 6-7 at 700 px/mm, defocus disc 3.4 px, 40 dB", 4);
}

TEST_CASE("chart: defocus disc, groups 2-3 at 80 px/mm, limit in group 3, no hint") {
  TempDir dir("chart");
  ChartScene c;
  c.view = view_on(chart(), pair_center(chart(), 2), 80, 12);
  PsfOptions psf;
  psf.kind = PsfOptions::defocus_disc;
  psf.radius_px = 4.3;
  c.psf = psf;
  c.sensor = sensor_40db(5);
  const ChartRun run = render_and_measure(c, dir, "defocus23");
  check_true_limit_group(run, 3);
  check_against_truth(run, "groups 2-3 at 80 px/mm, defocus disc 4.3 px, 40 dB", 4);
}

TEST_CASE("chart: diffraction (f/28), groups 4-5 at 200 px/mm, limit in group 4, no hint") {
  TempDir dir("chart");
  ChartScene c;
  c.view = view_on(chart(), pair_center(chart(), 4), 200, -25);
  PsfOptions psf;
  psf.kind = PsfOptions::diffraction;
  psf.f_number = 28;
  psf.wavelength_um = 0.55;
  psf.pixel_pitch_um = 2.0;
  c.psf = psf;
  c.sensor = sensor_40db(9);
  const ChartRun run = render_and_measure(c, dir, "diffraction45");
  check_true_limit_group(run, 4);
  check_against_truth(run, "groups 4-5 at 200 px/mm, diffraction f/28, 40 dB", 4);
}

TEST_CASE("chart: the limit at an even group's element 1 (G2E1, lower right), no hint") {
  TempDir dir("chart");
  ChartScene c;
  c.view = view_at(36);
  c.view.roll_deg = 3;
  c.blur_sigma_px = 2.95;
  c.sensor = sensor_40db(17);
  const ChartRun run = render_and_measure(c, dir, "limit-e1");
  const Limits t = visible_truth_limits(run.truth, Criterion{});
  CHECK(t.horizontal.group == 2);
  CHECK(t.horizontal.element == 1);
  CHECK(t.vertical.element == 1);
  MESSAGE("anchor " << run.result.detection.anchor_description << "; predicted elements "
                    << run.result.detection.predicted_elements);
  check_against_truth(run, "limit at G2E1, Gaussian 2.95 px, 40 dB");
}

TEST_CASE("chart: groups 6-7 at 1000 px/mm, Gaussian 2 px, limit in group 7") {
  TempDir dir("chart");
  ChartScene c;
  c.layout = &fine_chart();
  c.view = view_on(fine_chart(), pair_center(fine_chart(), 6), 1000, 0);
  c.blur_sigma_px = 2.0;
  c.sensor = sensor_40db(31);
  ChartDetectOptions d;
  d.px_per_mm = 1000;
  const ChartRun run = render_and_measure(c, dir, "micro67-1000", d);
  check_true_limit_group(run, 7);
  check_against_truth(run, "groups 6-7 at 1000 px/mm, Gaussian 2 px, 40 dB", 4);
}
