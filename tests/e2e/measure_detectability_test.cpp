// End to end: the detectability limit (profiles/detectability.h) on
// simulated captures with known exposure and sensor, against the truth's
// own CNR; and what halving the exposure does to each limit.
#include <cmath>

#include <doctest/doctest.h>

#include "scene_fixtures.h"

using namespace tactres;
using namespace tactres::testing;

namespace {

// A blurred printed target (optical limit in group 1, far from the sampling
// limit) under little light: ground ~ photons * 0.6 * 0.85 electrons, gain
// 1 DN per electron so the quantisation does not dominate.
Scene dim_scene(double photons_at_unity) {
  ViewPose v;
  v.roll_deg = 3;
  Scene s = albedo_scene(v, 2.4);
  SensorOptions o;
  o.bit_depth = 12;
  o.full_well_e = 4000;
  o.gain_dn_per_e = 1.0;
  o.photons_at_unity = photons_at_unity;
  o.quantum_efficiency = 0.6;
  o.read_noise_e = 3;
  o.dark_signal_e = 0;
  o.seed = 7;
  s.effects.emplace_back(o);
  return s;
}

// A strict Rose threshold, so that light limits before the fiducials are
// lost in the noise (at k = 5 a printed target stays optics-limited until
// the fiducial search fails, ~50 e- on the ground).
constexpr double kStrictK = 20;

struct Run {
  Truth truth;
  Measurement measured;
};

Run run(double photons, const std::string& name) {
  TempDir dir(name);
  const Scene s = dim_scene(photons);
  const RenderResult r = render_scene(s, default_layout(), wide_angle_camera());
  const std::filesystem::path file = dir.path / "capture.png";
  write_image(file, r.image, r.bits);
  MeasureOptions options = MeasureOptions::for_preset(Preset::balanced);
  options.detectability.k = kStrictK;
  return {compute_truth(s, default_layout(), wide_angle_camera(), {kStrictK, 2.0}),
          measure_capture(load_image(file), default_layout(), &wide_angle_camera(), options)};
}

}  // namespace

TEST_CASE("detectability limit: within one element and 3 percent of the truth, and halving the light lowers it") {
  const Run bright = run(400, "dim400"), dim = run(200, "dim200");
  REQUIRE(bright.measured.usable);
  REQUIRE(dim.measured.usable);
  for (const BarOrientation o : {BarOrientation::horizontal_bars, BarOrientation::vertical_bars}) {
    CAPTURE(to_string(o));
    for (const Run* r : {&bright, &dim}) {
      const Limit& measured = r->measured.parts(o).detectability;
      const Limit& truth = o == BarOrientation::horizontal_bars ? r->truth.horizontal_parts.detectability
                                                                : r->truth.vertical_parts.detectability;
      // The scene is light-limited: the truth says so, and so does the measurement.
      CHECK((o == BarOrientation::horizontal_bars ? r->truth.horizontal_parts : r->truth.vertical_parts).limited_by ==
            LimitingFactor::light_noise);
      CHECK(r->measured.parts(o).limited_by == LimitingFactor::light_noise);
      REQUIRE(measured.interpolated_lp_per_mm);
      REQUIRE(truth.interpolated_lp_per_mm);
      const double rel = *measured.interpolated_lp_per_mm / *truth.interpolated_lp_per_mm - 1;
      CHECK(std::abs(rel) <= 0.03);
      CHECK(discrete_limit_agrees(measured, truth));
      MESSAGE("detectability " << *measured.interpolated_lp_per_mm << " vs true " << *truth.interpolated_lp_per_mm
                               << " (" << 100 * rel << " %)");
    }
    // Half the light: detection gets coarser, the optics do not change.
    const Limit& d_bright = bright.measured.parts(o).detectability;
    const Limit& d_dim = dim.measured.parts(o).detectability;
    CHECK(*d_dim.interpolated_lp_per_mm < *d_bright.interpolated_lp_per_mm);
    const Limit& o_bright = bright.measured.parts(o).optical;
    const Limit& o_dim = dim.measured.parts(o).optical;
    REQUIRE(o_bright.interpolated_lp_per_mm);
    REQUIRE(o_dim.interpolated_lp_per_mm);
    const double sigma = std::hypot(o_bright.uncertainty_lp_per_mm.value_or(0), o_dim.uncertainty_lp_per_mm.value_or(0));
    CHECK(std::abs(*o_dim.interpolated_lp_per_mm - *o_bright.interpolated_lp_per_mm) <= 2 * sigma);
    // The reported limit follows the light.
    CHECK(bright.measured.parts(o).reported().lp_per_mm == d_bright.lp_per_mm);
  }
}
