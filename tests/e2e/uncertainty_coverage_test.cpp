// Is the reported uncertainty honest? Over many noisy captures of one scene,
// about 95% of the 2-sigma intervals must cover the truth.
#include <cmath>

#include <doctest/doctest.h>

#include "scene_fixtures.h"
#include "tactres/simulate/effects/sensor_model.h"

using namespace tactres;
using namespace tactres::testing;

TEST_CASE("2-sigma intervals of m and of the limit cover the truth about 95% of the time") {
  TempDir dir("coverage");
  ViewPose v;
  v.roll_deg = 5;
  const Scene scene = albedo_scene(v, 1.3);
  // Render the noise-free irradiance once; each repeat adds fresh noise.
  const RenderResult clean = render_scene(scene, default_layout(), wide_angle_camera());
  const Truth truth = compute_truth(scene, default_layout(), wide_angle_camera());
  const int repeats = 50;
  int m_total = 0, m_covered = 0, limit_total = 0, limit_covered = 0;
  double sum_z2 = 0;
  for (int rep = 0; rep < repeats; ++rep) {
    const SensorOptions sensor = sensor_40db(1000 + rep);
    const cv::Mat noisy = apply_sensor(clean.image, sensor);
    const auto file = dir.path / "capture.png";
    write_image(file, noisy, sensor.bit_depth);
    const Measurement m = measure_file(file, &wide_angle_camera());
    REQUIRE(m.usable);
    for (const ElementResult& e : m.elements) {
      if (e.status != ElementStatus::ok) continue;
      const TruthElement* t = truth_of(truth, e);
      REQUIRE(t);
      ++m_total;
      sum_z2 += std::pow((e.m - t->m) / e.m_sigma, 2);
      m_covered += std::abs(e.m - t->m) <= 2 * e.m_sigma ? 1 : 0;
    }
    for (const auto& [measured, true_limit] : {std::pair(m.horizontal, truth.horizontal), std::pair(m.vertical, truth.vertical)}) {
      if (!measured.interpolated_lp_per_mm || !true_limit.interpolated_lp_per_mm) continue;
      ++limit_total;
      limit_covered += std::abs(*measured.interpolated_lp_per_mm - *true_limit.interpolated_lp_per_mm) <=
                               2 * measured.uncertainty_lp_per_mm.value_or(0)
                           ? 1
                           : 0;
    }
  }
  const double m_rate = double(m_covered) / m_total;
  const double limit_rate = double(limit_covered) / limit_total;
  MESSAGE("2-sigma coverage over " << repeats << " repeats: m " << 100 * m_rate << "% of " << m_total
                                   << " element fits; interpolated limit " << 100 * limit_rate << "% of "
                                   << limit_total << "; RMS z of m " << std::sqrt(sum_z2 / m_total));
  CHECK(m_total > repeats * 20);
  CHECK(m_rate >= 0.88);
  CHECK(m_rate <= 0.995);
  CHECK(limit_total >= repeats * 2 * 9 / 10);
  CHECK(limit_rate >= 0.85);
}
