#include "tactres/simulate/truth.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <nlohmann/json.hpp>

#include "tactres/simulate/effects/psf.h"
#include "tactres/camera/target_view.h"

namespace tactres {
namespace {

constexpr double kPi = std::numbers::pi;

double sinc(double x) { return std::abs(x) < 1e-12 ? 1.0 : std::sin(kPi * x) / (kPi * x); }

// Sine response of full Lambert shading relative to its linearisation, at
// slope amplitude `slope_amp` along a unit direction (ux, uy).
double lambert_sine_ratio(const ShadingEffect& sh, double slope_amp, double ux, double uy) {
  const int n = 512;
  double c1 = 0, c1_lin = 0;
  for (int k = 0; k < n; ++k) {
    const double phase = 2 * kPi * (k + 0.5) / n;
    const double slope = slope_amp * std::sin(phase);  // df/du
    const double nx = -slope * ux, ny = -slope * uy;
    const double inv_len = 1.0 / std::sqrt(1 + slope * slope);
    double r = 0, r_lin = 0;
    for (const Light& li : sh.lights) {
      const double az = li.azimuth_deg * kPi / 180, el = li.elevation_deg * kPi / 180;
      const double l[3] = {std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)};
      const double d = nx * l[0] + ny * l[1] + l[2];
      r += li.weight * std::max(0.0, d * inv_len);
      r_lin += li.weight * d;
    }
    c1 += r * std::sin(phase);
    c1_lin += r_lin * std::sin(phase);
  }
  return std::abs(c1_lin) > 1e-15 ? c1 / c1_lin : 1.0;
}

}  // namespace

Truth compute_truth(const Scene& scene, const TargetLayout& layout, const CameraModel& camera) {
  Truth t;
  const TargetView view(camera, scene.rt_camera_from_target(layout));
  t.seen_from_behind = view.seen_from_behind();
  const PsfOptions* psf = scene.find<PsfOptions>();
  const ContactEffect* contact = scene.find<ContactEffect>();
  const ShadingEffect* shading = scene.find<ShadingEffect>();
  const bool gel = scene.target == TargetKind::relief && contact;
  const int W = camera.imager_width(), H = camera.imager_height();

  for (const ElementLayout& e : layout.elements) {
    TruthElement te;
    te.group = e.group;
    te.element = e.element;
    te.orientation = e.orientation;
    te.lp_per_mm = e.lp_per_mm;
    const auto pj = view.project_with_jacobian(e.extent_mm().center_mm());
    if (!pj) {
      te.in_view = false;
      t.elements.push_back(te);
      continue;
    }
    te.center_px = pj->first;
    const RectMm ext = e.extent_mm();
    for (Vec2 corner : {Vec2{ext.x0, ext.y0}, Vec2{ext.x1, ext.y0}, Vec2{ext.x0, ext.y1}, Vec2{ext.x1, ext.y1}}) {
      const auto q = view.project(corner);
      if (!q || q->x < 0 || q->y < 0 || q->x > W - 1 || q->y > H - 1) te.in_view = false;
    }
    const auto& J = pj->second;  // d px / d mm, row-major
    const bool horizontal = e.orientation == BarOrientation::horizontal_bars;
    // Target wave vector (cycles/mm) across the bars.
    const double kx = horizontal ? 0 : e.lp_per_mm, ky = horizontal ? e.lp_per_mm : 0;
    // k_img = J^-T k_t
    const double det = J[0] * J[3] - J[1] * J[2];
    const double ix = (J[3] * kx - J[2] * ky) / det;
    const double iy = (-J[1] * kx + J[0] * ky) / det;
    const double nu_px = std::hypot(ix, iy);
    te.px_per_bar = e.bar_width_mm * view.px_per_mm_across(e.extent_mm().center_mm(), e.orientation);

    double m = sinc(ix) * sinc(iy);
    if (psf) m *= psf_mtf(*psf, nu_px);
    if (gel) m *= std::exp(-2 * kPi * kPi * contact->sigma_mm * contact->sigma_mm * e.lp_per_mm * e.lp_per_mm);
    if (gel && shading && shading->model == ShadingEffect::Model::lambert) {
      const double amp = 0.5 * contact->depth_fraction * layout.relief_height_mm *
                         std::exp(-2 * kPi * kPi * contact->sigma_mm * contact->sigma_mm * e.lp_per_mm * e.lp_per_mm);
      m *= lambert_sine_ratio(*shading, amp * 2 * kPi * e.lp_per_mm, horizontal ? 0 : 1, horizontal ? 1 : 0);
      te.analytic = false;
    }
    te.m = m;
    t.elements.push_back(te);
  }

  std::vector<OrientedPoint> pts;
  for (const TruthElement& te : t.elements)
    pts.push_back({te.orientation, {te.group, te.element, te.lp_per_mm, te.m, 0.0, te.in_view}});
  Criterion exact = scene.criterion;
  exact.significance_z = 0;  // the truth is exact
  const Limits limits = find_limits(pts, exact);
  t.horizontal = limits.horizontal;
  t.vertical = limits.vertical;

  const TargetView::Nyquist nyq = view.nyquist({0.5 * layout.width_mm, 0.5 * layout.height_mm});
  t.nyquist_h_lp_per_mm = nyq.horizontal_bars_lp_per_mm;
  t.nyquist_v_lp_per_mm = nyq.vertical_bars_lp_per_mm;
  return t;
}

nlohmann::json truth_to_json(const Truth& t, const Scene& scene, const std::string& image_name) {
  nlohmann::json j;
  j["schema"] = kTruthSchema;
  j["image"] = image_name;
  j["scene"] = scene.source.filename().string();
  j["design"] = scene.design;
  j["criterion"] = {{"threshold", scene.criterion.threshold}};
  j["seen_from_behind"] = t.seen_from_behind;
  j["nyquist_lp_per_mm"] = {{"horizontal_bars", t.nyquist_h_lp_per_mm},
                            {"vertical_bars", t.nyquist_v_lp_per_mm}};
  nlohmann::json els = nlohmann::json::array();
  for (const TruthElement& e : t.elements)
    els.push_back({{"group", e.group},
                   {"element", e.element},
                   {"orientation", to_string(e.orientation)},
                   {"lp_per_mm", e.lp_per_mm},
                   {"m", e.m},
                   {"analytic", e.analytic},
                   {"px_per_bar", e.px_per_bar},
                   {"center_px", {e.center_px.x, e.center_px.y}},
                   {"in_view", e.in_view}});
  j["elements"] = els;
  j["limits"] = {{"horizontal_bars", limit_to_json(t.horizontal)}, {"vertical_bars", limit_to_json(t.vertical)}};
  return j;
}

}  // namespace tactres
