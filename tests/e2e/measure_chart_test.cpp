// End to end: simulated photographs of the standard USAF-1951 chart
// (MIL-STD-150A arrangement, `make_mil_std_chart`), measured with no layout
// and no fiducials (`measure_chart`), compared with the simulator's analytic
// truth (docs/CHART.md).
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <map>

#include <sys/wait.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <doctest/doctest.h>
#include <nlohmann/json.hpp>

#include "scene_fixtures.h"
#include "tactres/measure/chart_measure.h"
#include "tactres/measure/measurement_io.h"
#include "tactres/targets/mil_std_chart.h"

using namespace tactres;
using namespace tactres::testing;

namespace {

// Groups 0..5: three nested pairs, 22 x 17 mm.
const TargetLayout& chart(Polarity polarity = Polarity::dark_bars_on_light) {
  static std::map<Polarity, TargetLayout> cache;
  auto it = cache.find(polarity);
  if (it == cache.end()) {
    MilStdChartOptions o;
    o.first_group = 0;
    o.last_group = 5;
    o.polarity = polarity;
    it = cache.emplace(polarity, make_mil_std_chart(o)).first;
  }
  return it->second;
}

struct ChartScene {
  ViewPose view;
  double blur_sigma_px = 2.0;
  Polarity polarity = Polarity::dark_bars_on_light;
  std::optional<SensorOptions> sensor;
  const TargetLayout* layout = nullptr;  // default: chart(polarity)
  std::optional<PsfOptions> psf;         // default: Gaussian of blur_sigma_px
};

Scene scene_of(const ChartScene& c) {
  Scene s = albedo_scene(c.view, c.blur_sigma_px, 3);
  if (c.polarity == Polarity::light_bars_on_dark) std::swap(s.ink_reflectance, s.ground_reflectance);
  if (c.psf) s.effects.at(0) = *c.psf;
  if (c.sensor) s.effects.emplace_back(*c.sensor);
  return s;
}

struct ChartRun {
  std::filesystem::path file;
  Truth truth;
  ChartMeasurement result;
};

ChartRun render_and_measure(const ChartScene& c, const TempDir& dir, const std::string& name,
                            const ChartDetectOptions& detect = {}) {
  const Scene s = scene_of(c);
  const TargetLayout& L = c.layout ? *c.layout : chart(c.polarity);
  const RenderResult r = render_scene(s, L, pinhole_camera());
  ChartRun run;
  run.file = dir.path / (name + (r.bits > 0 ? ".png" : ".tif"));
  write_image(run.file, r.image, r.bits);
  run.truth = compute_truth(s, L, pinhole_camera());
  ChartMeasureOptions o;
  o.detect = detect;
  run.result = measure_chart(load_image(run.file), o);
  return run;
}

// The view centred on the chart at a distance giving `px_per_mm`.
ViewPose view_at(double px_per_mm) {
  ViewPose v;
  v.distance_mm = 560.0 / px_per_mm;  // the example pinhole: f = 560 px
  return v;
}

const TruthElement* truth_for(const Truth& t, int g, int e, BarOrientation o) {
  for (const TruthElement& te : t.elements)
    if (te.group == g && te.element == e && te.orientation == o) return &te;
  return nullptr;
}

// The true limits among the elements the measurement could see: those in
// view with at least the sampling minimum (1.5 px per bar). Elements out of
// view are dropped, not counted as unresolved, so a view of a few groups
// has a true limit too.
Limits visible_truth_limits(const Truth& t, const Criterion& c) {
  std::vector<OrientedPoint> pts;
  for (const TruthElement& te : t.elements) {
    if (!te.in_view) continue;
    pts.push_back({te.orientation, {te.group, te.element, te.lp_per_mm, te.m, 0.0, te.px_per_bar >= 1.5}});
  }
  return find_limits(pts, c);
}

// The acceptance checks of issue 8 for one capture. Unanchored results are
// relative (largest element found = G0E1); they are compared with the truth
// after the shift that the element matching finds, which must be the same
// for every element.
void check_against_truth(const ChartRun& run, const std::string& label, int min_visible = 6) {
  CAPTURE(label);
  const ChartDetection& D = run.result.detection;
  const Measurement& M = run.result.measurement;
  CAPTURE(M.problem);
  REQUIRE(D.found);
  REQUIRE(M.usable);
  // Every clearly visible element (in view with its neighbourhood, >= 2.5 px
  // per bar, both patterns at m >= 0.3) is found and correctly indexed.
  int visible = 0, found = 0;
  std::optional<int> shift;  // truth index - reported index
  bool consistent = true;
  for (const TruthElement& te : run.truth.elements) {
    if (te.orientation != BarOrientation::horizontal_bars) continue;
    const TruthElement* tv = truth_for(run.truth, te.group, te.element, BarOrientation::vertical_bars);
    if (!te.in_view || !tv || !tv->in_view || te.px_per_bar < 2.5 || te.m < 0.3 || tv->m < 0.3) continue;
    const double margin = 12 * te.px_per_bar;
    const double xs[] = {te.center_px.x, tv->center_px.x}, ys[] = {te.center_px.y, tv->center_px.y};
    bool inside = true;
    for (int k = 0; k < 2; ++k)
      inside = inside && xs[k] > margin && ys[k] > margin && xs[k] < 1279 - margin && ys[k] < 719 - margin;
    if (!inside) continue;
    ++visible;
    bool hit = false;
    for (const ChartElement& e : D.elements) {
      if (norm(D.patterns[e.h].center_px - te.center_px) > 2 * te.px_per_bar) continue;
      hit = true;
      const int d = (6 * te.group + te.element - 1) - (6 * e.group + e.element - 1);
      if (!shift) shift = d;
      consistent = consistent && d == *shift;
    }
    if (!hit && std::getenv("TACTRES_CHART_DEBUG"))
      for (const BarPattern& p : D.patterns)
        if (norm(p.center_px - te.center_px) < 40 * te.px_per_bar || norm(p.center_px - tv->center_px) < 40 * te.px_per_bar)
          MESSAGE("near the missed element: pattern at " << p.center_px.x << "," << p.center_px.y << " period " << p.period_px
                  << " dir " << p.bar_dir.x << "," << p.bar_dir.y << "; truth H at " << te.center_px.x << "," << te.center_px.y
                  << " V at " << tv->center_px.x << "," << tv->center_px.y);
    CHECK_MESSAGE(hit, "G" << te.group << "E" << te.element << " (" << te.px_per_bar << " px/bar, m " << te.m << ") not found");
    found += hit;
  }
  CHECK(visible >= min_visible);
  if (std::getenv("TACTRES_CHART_DUMP")) {
    std::ofstream f(std::getenv("TACTRES_CHART_DUMP"));
    for (const BarPattern& p : D.patterns)
      f << "P " << p.center_px.x << " " << p.center_px.y << " " << p.period_px << " " << p.bar_dir.x << " " << p.bar_dir.y << "\n";
    for (const ChartElement& e : D.elements)
      f << "E " << e.group << " " << e.element << " " << D.patterns[e.h].center_px.x << " " << D.patterns[e.h].center_px.y
        << " " << D.patterns[e.v].center_px.x << " " << D.patterns[e.v].center_px.y << " " << e.period_px << "\n";
    for (const TruthElement& te : run.truth.elements)
      f << "T " << te.group << " " << te.element << " " << to_string(te.orientation) << " " << te.center_px.x << " "
        << te.center_px.y << " " << te.px_per_bar << " " << te.m << "\n";
  }
  REQUIRE(shift);
  CHECK(consistent);
  if (D.anchor == ChartAnchor::none) {
    CHECK(D.elements.front().group == 0);
    CHECK(D.elements.front().element == 1);
  } else {
    CHECK(*shift == 0);  // absolute indices are right
  }
  const double scale = std::exp2(*shift / 6.0);  // relative lp/mm -> true lp/mm
  // m agrees where the bars are well sampled.
  double worst_dm = 0;
  for (const ElementResult& e : M.elements) {
    const int n = 6 * e.group + e.element - 1 + *shift;
    const int g = n >= 0 ? n / 6 : -((-n + 5) / 6);
    const TruthElement* t = truth_for(run.truth, g, n - 6 * g + 1, e.orientation);
    REQUIRE(t);
    if (e.status == ElementStatus::ok && t->px_per_bar >= 2.5) worst_dm = std::max(worst_dm, std::abs(e.m - t->m));
    if (std::getenv("TACTRES_CHART_DEBUG"))
      MESSAGE("G" << g << "E" << n - 6 * g + 1 << " " << std::string(to_string(e.orientation)) << " " << e.px_per_bar << " px/bar: m "
                  << e.m << " +- " << e.m_sigma << " true " << t->m << " (" << t->px_per_bar << ") "
                  << std::string(to_string(e.status)) << " chi2 " << e.chi2_reduced << " beta " << e.beta << " centre error "
                  << norm(0.25 * (e.outline_px[0] + e.outline_px[1] + e.outline_px[2] + e.outline_px[3]) - t->center_px)
                  << " px");
  }
  CHECK(worst_dm <= 0.05);
  if (std::getenv("TACTRES_CHART_DEBUG"))
    MESSAGE("contrast x " << M.reference.vertical_bars.contrast << " +- " << M.reference.vertical_bars.contrast_sigma << ", y " << M.reference.horizontal_bars.contrast
                          << " +- " << M.reference.horizontal_bars.contrast_sigma);
  const Limits truth = visible_truth_limits(run.truth, Criterion{});
  for (const auto& [reported, want, name] :
       {std::tuple(M.horizontal, truth.horizontal, std::string("H")), std::tuple(M.vertical, truth.vertical, std::string("V"))}) {
    CAPTURE(name);
    REQUIRE(reported.any_resolved);
    REQUIRE(want.any_resolved);
    Limit measured = reported;  // in true units
    const int n = 6 * measured.group + measured.element - 1 + *shift;
    measured.group = n >= 0 ? n / 6 : -((-n + 5) / 6);
    measured.element = n - 6 * measured.group + 1;
    measured.lp_per_mm *= scale;
    if (measured.interpolated_lp_per_mm) *measured.interpolated_lp_per_mm *= scale;
    if (measured.uncertainty_lp_per_mm) *measured.uncertainty_lp_per_mm *= scale;
    // No false resolution beyond the truth (one element, inside the band, at most).
    CHECK(measured.lp_per_mm <= want.lp_per_mm * std::exp2(1.0 / 6) * 1.001);
    CHECK(discrete_limit_agrees(measured, want));
    REQUIRE(want.interpolated_lp_per_mm);
    REQUIRE(measured.interpolated_lp_per_mm);
    const double rel = *measured.interpolated_lp_per_mm / *want.interpolated_lp_per_mm - 1;
    CHECK(std::abs(rel) <= 0.03);
    MESSAGE(label << " " << name << ": G" << measured.group << "E" << measured.element << " (true G" << want.group << "E"
                  << want.element << "), interpolated " << *measured.interpolated_lp_per_mm << " vs true "
                  << *want.interpolated_lp_per_mm << " lp/mm (" << 100 * rel << " %); " << found << "/" << visible
                  << " visible elements found; worst |dm| " << worst_dm << "; anchor " << std::string(to_string(D.anchor)));
  }
}

// A view that puts chart point `p_mm` on the optical axis (direct view,
// roll only).
ViewPose view_on(const TargetLayout& L, Vec2 p_mm, double px_per_mm, double roll_deg) {
  ViewPose v = view_at(px_per_mm);
  v.roll_deg = roll_deg;
  const double a = roll_deg * M_PI / 180;
  const Vec2 d{p_mm.x - 0.5 * L.width_mm, p_mm.y - 0.5 * L.height_mm};
  v.offset_mm = {-(std::cos(a) * d.x - std::sin(a) * d.y), -(std::sin(a) * d.x + std::cos(a) * d.y)};
  return v;
}

// Centre of the pair (g, g+1) in the chart.
Vec2 pair_center(const TargetLayout& L, int g) {
  RectMm b{1e300, 1e300, -1e300, -1e300};
  for (const ElementLayout& e : L.elements)
    if (e.group == g || e.group == g + 1) b = bounding_union(b, e.extent_mm());
  return b.center_mm();
}

}  // namespace

TEST_CASE("chart: positive chart, whole chart in view, anchored by --px-per-mm") {
  TempDir dir("chart");
  ChartScene c;
  c.view = view_at(36);
  c.view.roll_deg = 3;
  ChartDetectOptions d;
  d.px_per_mm = 36;
  check_against_truth(render_and_measure(c, dir, "positive", d), "positive, 36 px/mm, sigma 2 px");
}

TEST_CASE("chart: negative chart rotated 90 degrees, anchored by --largest-group") {
  TempDir dir("chart");
  ChartScene c;
  c.view = view_at(30);
  c.view.roll_deg = 90;
  c.polarity = Polarity::light_bars_on_dark;
  c.blur_sigma_px = 1.7;
  ChartDetectOptions d;
  d.largest_group = 0;
  const ChartRun run = render_and_measure(c, dir, "negative90", d);
  CHECK(run.result.detection.light_bars);
  check_against_truth(run, "negative, 90 deg, sigma 1.7 px");
}

TEST_CASE("chart: rotated 180 degrees and mirrored (seen from behind), no hint: anchored by the arrangement") {
  TempDir dir("chart");
  ChartScene c;
  c.view = view_at(34);
  c.view.view = "through_gel";
  c.view.roll_deg = 180;
  const ChartRun run = render_and_measure(c, dir, "mirrored180");
  const ChartDetection& D = run.result.detection;
  CAPTURE(D.anchor_description);
  CHECK(D.anchor == ChartAnchor::arrangement);  // check_against_truth then requires the true groups
  CHECK(D.arrangement.recognised);
  CHECK(D.arrangement.mirrored);
  CHECK(D.arrangement.labels_read >= 1);
  check_against_truth(run, "mirrored, 180 deg, anchor: arrangement");
}

TEST_CASE("chart: a direct view with no hint is anchored by the arrangement, not mirrored") {
  TempDir dir("chart");
  ChartScene c;
  c.view = view_at(36);
  c.view.roll_deg = 20;
  const ChartRun run = render_and_measure(c, dir, "direct-arrangement");
  const ChartDetection& D = run.result.detection;
  CAPTURE(D.anchor_description);
  CHECK(D.anchor == ChartAnchor::arrangement);
  CHECK_FALSE(D.arrangement.mirrored);
  check_against_truth(run, "direct, 20 deg, anchor: arrangement");
}

TEST_CASE("chart: another arrangement (the project's packed target) is not taken for MIL-STD-150A: anchor none") {
  TempDir dir("chart");
  ChartScene c;
  c.view = view_at(30);
  c.layout = &default_layout();
  const ChartRun run = render_and_measure(c, dir, "packed");
  const ChartDetection& D = run.result.detection;
  REQUIRE(D.found);
  CAPTURE(D.arrangement.note);
  CHECK(D.elements.size() >= 8);  // enough elements that the arrangement could have been tested
  CHECK_FALSE(D.arrangement.recognised);
  CHECK(D.anchor == ChartAnchor::none);
  CHECK(D.anchor_description.find("arrangement not recognised") != std::string::npos);
  CHECK(D.elements.front().group == 0);
  CHECK(D.elements.front().element == 1);
}

TEST_CASE("chart: 15 degree perspective, 37 degree roll, 40 dB noise") {
  TempDir dir("chart");
  ChartScene c;
  c.view = view_at(36);
  c.view.tilt_deg = 15;
  c.view.tilt_axis_deg = 30;
  c.view.roll_deg = 37;
  c.sensor = sensor_40db(11);
  ChartDetectOptions d;
  d.largest_group = 0;
  check_against_truth(render_and_measure(c, dir, "perspective", d), "15 deg tilt, 40 dB");
}

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

// The groups 4..7 chart, for views under a microscope.
const TargetLayout& fine_chart() {
  static const TargetLayout fine = [] {
    MilStdChartOptions o;
    o.first_group = 4;
    o.last_group = 7;
    return make_mil_std_chart(o);
  }();
  return fine;
}

// The true limit of a run is in `group` for both orientations (so that a
// case claims what it covers).
void check_true_limit_group(const ChartRun& run, int group) {
  const Limits t = visible_truth_limits(run.truth, Criterion{});
  CHECK(t.horizontal.group == group);
  CHECK(t.vertical.group == group);
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

TEST_CASE("chart: elements cut by the image edge get a status, never a measurement") {
  TempDir dir("chart");
  ChartScene c;
  // The right image edge at chart x = 18.75 mm: between the H and V
  // triplets of group 1's coarse elements.
  c.view = view_on(chart(), {18.75 - 639.5 / 36, 0.5 * chart().height_mm}, 36, 0);
  ChartDetectOptions d;
  d.px_per_mm = 36;
  const ChartRun run = render_and_measure(c, dir, "cut", d);
  const ChartDetection& D = run.result.detection;
  const Measurement& M = run.result.measurement;
  REQUIRE(D.found);
  REQUIRE(M.usable);
  // Elements whose H triplet is in view and whose V triplet is not.
  int cut = 0;
  for (const TruthElement& te : run.truth.elements) {
    if (te.orientation != BarOrientation::horizontal_bars || !te.in_view || te.px_per_bar < 3) continue;
    const TruthElement* tv = truth_for(run.truth, te.group, te.element, BarOrientation::vertical_bars);
    if (!tv || tv->in_view) continue;
    ++cut;
    CAPTURE(te.group);
    CAPTURE(te.element);
    int reported = 0;
    for (const ElementResult& e : M.elements) {
      if (e.group != te.group || e.element != te.element) continue;
      ++reported;
      CHECK(e.status == ElementStatus::out_of_view);
      CHECK_FALSE(e.resolved);
    }
    CHECK(reported == 2);  // both orientations, graded
  }
  CHECK(cut >= 2);
  CHECK(D.partial.size() >= 2);
  const nlohmann::json j = chart_to_json(D);
  REQUIRE(j["partial_elements"].size() == D.partial.size());
  for (const auto& p : j["partial_elements"]) {
    CHECK(p["status"] == "out_of_view");
    CHECK(p["found"] == "horizontal_bars");
    CHECK(p["reason"].get<std::string>().find("outside the image") != std::string::npos);
  }
  // The elements in full view still give the true limit.
  const Limits truth = visible_truth_limits(run.truth, Criterion{});
  CHECK(discrete_limit_agrees(M.horizontal, truth.horizontal));
  CHECK(discrete_limit_agrees(M.vertical, truth.vertical));
  MESSAGE(cut << " elements cut by the edge, " << D.partial.size() << " reported as partial");
}

TEST_CASE("chart: an element with one pattern wiped off gets fit_failed with the reason, never a measurement") {
  TempDir dir("chart");
  ChartScene c;
  c.view = view_at(36);
  c.view.roll_deg = 3;
  const Scene s = scene_of(c);
  const RenderResult r = render_scene(s, chart(), pinhole_camera());
  ChartRun run;
  run.truth = compute_truth(s, chart(), pinhole_camera());
  // Wipe G1E1's vertical-bar triplet: paint its box with the paper level.
  const TruthElement* tv = truth_for(run.truth, 1, 1, BarOrientation::vertical_bars);
  REQUIRE(tv);
  cv::Mat img = r.image.clone();
  const double half = 4 * tv->px_per_bar;
  const cv::Rect box(static_cast<int>(tv->center_px.x - half), static_cast<int>(tv->center_px.y - half),
                     static_cast<int>(2 * half), static_cast<int>(2 * half));
  double lo = 0, paper = 0;
  cv::minMaxLoc(img(box), &lo, &paper);
  img(box).setTo(paper);
  run.file = dir.path / "wiped.tif";
  write_image(run.file, img);
  ChartMeasureOptions o;
  o.detect.px_per_mm = 36;
  run.result = measure_chart(load_image(run.file), o);
  const ChartDetection& D = run.result.detection;
  const Measurement& M = run.result.measurement;
  REQUIRE(D.found);
  REQUIRE(M.usable);
  int reported = 0;
  for (const ElementResult& e : M.elements) {
    if (e.group != 1 || e.element != 1) continue;
    ++reported;
    CHECK(e.status == ElementStatus::fit_failed);
    CHECK_FALSE(e.resolved);
    CHECK(e.m == 0);
  }
  CHECK(reported == 2);
  const nlohmann::json j = chart_to_json(D);
  bool listed = false;
  for (const auto& p : j["partial_elements"])
    if (p["group"] == 1 && p["element"] == 1) {
      listed = true;
      CHECK(p["status"] == "fit_failed");
      CHECK(p["found"] == "horizontal_bars");
      CHECK(p["reason"].get<std::string>().find("was not found there") != std::string::npos);
    }
  CHECK(listed);
  // Left out of the limits: the rest still gives the true limit.
  const Limits truth = visible_truth_limits(run.truth, Criterion{});
  CHECK(discrete_limit_agrees(M.horizontal, truth.horizontal));
  CHECK(discrete_limit_agrees(M.vertical, truth.vertical));
}

namespace {

// A capture of the whole chart as a phone or a bench camera would take it:
// uneven light (a diffuser off to one side), cos^4 vignetting, a little
// noise, then dust specks on the print, drawn into the rendered image.
ChartRun render_photo(const TempDir& dir, const std::string& name, bool jpeg, const ChartDetectOptions& detect) {
  ChartScene c;
  c.view = view_at(36);
  c.view.roll_deg = -8;
  Scene s = scene_of(c);
  s.effects.clear();
  IlluminationOptions light;
  light.aperture_width_mm = 12;
  light.distance_mm = 14;
  light.aperture_center_mm = {0.2 * chart().width_mm, 0.3 * chart().height_mm};
  s.effects.emplace_back(light);
  PsfOptions psf;
  psf.sigma_px = 2.0;
  s.effects.emplace_back(psf);
  s.effects.emplace_back(VignettingEffect{4.0});
  RenderResult r = render_scene(s, chart(), pinhole_camera());
  cv::Mat img = r.image.clone();  // float, linear
  cv::RNG rng(7);
  for (int k = 0; k < 60; ++k) {
    const cv::Point p(rng.uniform(0, img.cols), rng.uniform(0, img.rows));
    cv::circle(img, p, rng.uniform(1, 4), cv::Scalar(0.02), cv::FILLED, cv::LINE_AA);
  }
  ChartRun run;
  if (jpeg) {
    // 8-bit sRGB, as phones write it: encode, then let the loader decode.
    cv::Mat srgb(img.size(), CV_8U);
    for (int y = 0; y < img.rows; ++y)
      for (int x = 0; x < img.cols; ++x) {
        const float v = std::clamp(img.at<float>(y, x), 0.f, 1.f);
        const float e = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1 / 2.4f) - 0.055f;
        srgb.at<unsigned char>(y, x) = static_cast<unsigned char>(std::lround(255 * e));
      }
    run.file = dir.path / (name + ".jpg");
    write_image(run.file, srgb);
  } else {
    cv::Mat noisy = img.clone();
    cv::Mat noise(img.size(), CV_32F);
    cv::randn(noise, 0, 0.004);
    noisy += noise;
    run.file = dir.path / (name + ".tif");
    write_image(run.file, noisy);
  }
  run.truth = compute_truth(s, chart(), pinhole_camera());
  ChartMeasureOptions o;
  o.detect = detect;
  const LoadedImage loaded = load_image(run.file);
  if (jpeg) CHECK(loaded.transfer.curve.name() == "srgb");
  run.result = measure_chart(loaded, o);
  return run;
}

}  // namespace

TEST_CASE("chart: uneven light, vignetting, dust specks and noise, digits and the large square are not bars") {
  TempDir dir("chart");
  ChartDetectOptions d;
  d.largest_group = 0;
  const ChartRun run = render_photo(dir, "photo", false, d);
  check_against_truth(run, "uneven light, vignetting, dust");
  // Every measured pattern is a chart element: none on the large square, a
  // digit or a dust speck (stray triplets stay unpaired and unmeasured).
  const ChartDetection& D = run.result.detection;
  for (const ChartElement& e : D.elements)
    for (int k : {e.h, e.v}) {
    const BarPattern& p = D.patterns[k];
    bool on_element = false;
    for (const TruthElement& te : run.truth.elements)
      on_element = on_element || norm(te.center_px - p.center_px) < 1.5 * te.px_per_bar;
    CHECK_MESSAGE(on_element, "a pattern at " << p.center_px.x << "," << p.center_px.y << " is not a chart element");
    }
  MESSAGE(D.patterns.size() << " patterns, " << D.elements.size() << " elements (" << D.predicted_elements
                            << " predicted), " << D.unpaired_patterns << " unpaired patterns");
}

TEST_CASE("chart: an 8-bit sRGB JPEG (linearised on load)") {
  TempDir dir("chart");
  ChartDetectOptions d;
  d.px_per_mm = 36;
  check_against_truth(render_photo(dir, "phone", true, d), "8-bit sRGB JPEG");
}

namespace {
// `tactres measure IMAGE --chart usaf1951 -o JSON`: exit code and stderr.
int run_chart_cli(const std::filesystem::path& image, const std::filesystem::path& json, std::string& err) {
  const std::filesystem::path err_file = json.string() + ".err";
  const std::string cmd = std::string(TACTRES_BINARY) + " measure " + image.string() + " --chart usaf1951 -o " +
                          json.string() + " 2> " + err_file.string() + " > /dev/null";
  const int status = std::system(cmd.c_str());
  std::ifstream f(err_file);
  err.assign(std::istreambuf_iterator<char>(f), {});
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}
}  // namespace

TEST_CASE("chart CLI: a photograph with no chart is exit 2 with a clear message") {
  TempDir dir("chart-cli");
  cv::Mat img(480, 640, CV_32F);
  cv::randn(img, 0.5, 0.02);
  // Soft blobs and a gradient: structure, but no three-bar pattern.
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x)
      img.at<float>(y, x) += 0.2f * std::sin(x / 37.0) * std::cos(y / 23.0) + 0.0003f * x;
  const auto file = dir.path / "nochart.tif";
  write_image(file, img);
  std::string err;
  CHECK(run_chart_cli(file, dir.path / "nochart.json", err) == 2);
  CHECK(err.find("no USAF-1951 chart found") != std::string::npos);
  std::ifstream j(dir.path / "nochart.json");
  const nlohmann::json m = nlohmann::json::parse(j);
  CHECK(m["usable"] == false);
  CHECK(m["chart"]["found"] == false);
}

TEST_CASE("chart CLI: a chart so blurred that nothing resolves is exit 2, the coarsest element is unresolved") {
  TempDir dir("chart-cli");
  ChartScene c;
  c.view = view_at(36);
  c.blur_sigma_px = 12.5;  // m of G0E1 (18 px per bar) ~0.09
  const Scene s = scene_of(c);
  const RenderResult r = render_scene(s, chart(), pinhole_camera());
  const auto file = dir.path / "blurred.tif";
  write_image(file, r.image, r.bits);
  const Truth truth = compute_truth(s, chart(), pinhole_camera());
  CHECK_FALSE(visible_truth_limits(truth, Criterion{}).horizontal.any_resolved);
  std::string err;
  CHECK(run_chart_cli(file, dir.path / "blurred.json", err) == 2);
  CAPTURE(err);
  std::ifstream j(dir.path / "blurred.json");
  const nlohmann::json m = nlohmann::json::parse(j);
  CHECK(m["usable"] == false);
  if (m["chart"]["found"] == true) {
    REQUIRE(!m["elements"].empty());
    CHECK(m["elements"][0]["resolved"] == false);
    CHECK(err.find("nothing on the chart is resolved") != std::string::npos);
    MESSAGE("blurred chart: coarsest element found G" << m["elements"][0]["group"] << "E" << m["elements"][0]["element"]
                                                      << ", m " << m["elements"][0]["m"]);
  } else {
    CHECK(err.find("no USAF-1951 chart found") != std::string::npos);
    MESSAGE("blurred chart: not found at all");
  }
}
