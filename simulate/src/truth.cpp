#include "tactres/simulate/truth.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <utility>
#include <numbers>

#include <nlohmann/json.hpp>

#include "tactres/simulate/effects/illumination.h"
#include "tactres/simulate/effects/psf.h"
#include "tactres/simulate/effects/sensor_model.h"
#include "tactres/camera/target_view.h"

namespace tactres {
namespace {

constexpr double kPi = std::numbers::pi;

// The light map's origin (scene.h, ShadingEffect::light_map).
Vec2 layout_center(const TargetLayout& layout) { return {0.5 * layout.width_mm, 0.5 * layout.height_mm}; }

double sinc(double x) { return std::abs(x) < 1e-12 ? 1.0 : std::sin(kPi * x) / (kPi * x); }

// Sine response of full Lambert shading relative to its linearisation, at
// slope amplitude `slope_amp` along a unit direction (ux, uy).
double lambert_sine_ratio(const std::vector<Light>& lights, double slope_amp, double ux, double uy) {
  const int n = 512;
  double c1 = 0, c1_lin = 0;
  for (int k = 0; k < n; ++k) {
    const double phase = 2 * kPi * (k + 0.5) / n;
    const double slope = slope_amp * std::sin(phase);  // df/du
    const double nx = -slope * ux, ny = -slope * uy;
    const double inv_len = 1.0 / std::sqrt(1 + slope * slope);
    double r = 0, r_lin = 0;
    for (const Light& li : lights) {
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

// The ground level (input units, before the sensor) and the level step c
// an element's bars show, at target point `at_mm` with relative irradiance
// `light` and vignetting factor `vignetting` (profile_fit.h's model:
// P = B0 (1 + c D[S])); the shading's lights are those at that point.
// Absent where the scene gives no bar signal model.
struct LocalLevels {
  double ground = 0, contrast = 0;
  Signature signature = Signature::albedo;
};
std::optional<LocalLevels> local_levels(const Scene& scene, const TargetLayout& layout, BarOrientation bars,
                                        Vec2 at_mm, double light, double vignetting) {
  const double field = light * vignetting;
  if (scene.target == TargetKind::albedo) {
    if (!(scene.ground_reflectance > 0)) return std::nullopt;
    return LocalLevels{scene.ground_reflectance * field, scene.ink_reflectance / scene.ground_reflectance - 1,
                       Signature::albedo};
  }
  const ShadingEffect* sh = scene.find<ShadingEffect>();
  const ContactEffect* contact = scene.find<ContactEffect>();
  if (!sh || !contact) return std::nullopt;
  // Linearised Lambert: R = albedo sum w (l_z - h_x l_x - h_y l_y) + ambient,
  // h = depth_fraction * relief height * S: the ground is the flat
  // response, the step per unit dS/du the slope response along u.
  double flat = 0, along_u = 0;
  for (const Light& li : sh->lights_at(at_mm - layout_center(layout))) {
    const double az = li.azimuth_deg * kPi / 180, el = li.elevation_deg * kPi / 180;
    flat += li.weight * std::sin(el);
    along_u += li.weight * std::cos(el) * (bars == BarOrientation::vertical_bars ? std::cos(az) : std::sin(az));
  }
  const double ground = (sh->albedo * flat + sh->ambient) * field;
  if (!(ground > 0)) return std::nullopt;
  const double height_mm = contact->depth_fraction * layout.relief_height_mm;
  return LocalLevels{ground, -sh->albedo * height_mm * along_u * field / ground, Signature::shading};
}

// cos^n of the chief ray's angle at a pixel (the renderer's vignetting).
double vignetting_at(const Scene& scene, const CameraModel& camera, Vec2 px) {
  const VignettingEffect* v = scene.find<VignettingEffect>();
  if (!v) return 1.0;
  const auto rays = camera.unproject(std::vector<Vec2>{px});
  if (!rays.front()) return 1.0;
  const auto& r = *rays.front();
  return std::pow(r.z / std::sqrt(r.x * r.x + r.y * r.y + r.z * r.z), v->exponent);
}

// The RMS of the true level step across a relief element's triplet
// (profiles/detectability.h, rms_step_over_triplet): the light per point
// turns the step over the element, and where its in-plane part across the
// bars changes sign inside the triplet the outer bars still shade. 3-point
// Gauss-Legendre over |u| <= the half-width, u along x across vertical bars
// and along y across horizontal ones: exact for a step linear in u. In the
// centre's ground units (the noise is taken at the centre's level; the
// vignetting is the centre's). Printed targets: the centre's step.
double rms_true_step(const Scene& scene, const TargetLayout& layout, const TruthElement& te, Vec2 centre_mm,
                     const std::optional<IlluminationField>& light, double vignetting, const LocalLevels& at_centre) {
  if (at_centre.signature != Signature::shading) return at_centre.contrast;
  const double half_mm = triplet_half_width_mm(te.lp_per_mm);
  const double node = std::sqrt(0.6);
  const std::array<std::pair<double, double>, 3> gauss = {{{-node, 5.0 / 18}, {0.0, 8.0 / 18}, {node, 5.0 / 18}}};
  double mean_sq = 0;
  for (const auto& [x, w] : gauss) {
    const Vec2 at = centre_mm + (te.orientation == BarOrientation::vertical_bars ? Vec2{x * half_mm, 0}
                                                                                   : Vec2{0, x * half_mm});
    const auto levels =
        local_levels(scene, layout, te.orientation, at, light ? light->exact_relative_irradiance(at) : 1.0, vignetting);
    if (!levels) return at_centre.contrast;
    mean_sq += w * std::pow(levels->contrast * levels->ground / at_centre.ground, 2);
  }
  return std::copysign(std::sqrt(mean_sq), at_centre.contrast);
}

// The true Rose CNR of every in-view element (truth.h).
void set_true_cnr(Truth& t, const Scene& scene, const TargetLayout& layout, const CameraModel& camera,
                  const TargetView& view) {
  const SensorOptions* sensor = scene.find<SensorOptions>();
  if (!sensor) return;
  std::optional<IlluminationField> light;
  if (const IlluminationOptions* ill = scene.find<IlluminationOptions>())
    light.emplace(target_illumination(*ill, layout.width_mm, layout.height_mm));  // as the renderer has it
  const double dn_per_input = sensor_mean_dn(*sensor, 1.0) - sensor_mean_dn(*sensor, 0.0);
  for (size_t i = 0; i < t.elements.size(); ++i) {
    TruthElement& te = t.elements[i];
    if (!te.in_view) continue;
    const Vec2 c = layout.elements[i].extent_mm().center_mm();
    const double vignetting = vignetting_at(scene, camera, te.center_px);
    const auto levels = local_levels(scene, layout, te.orientation, c,
                                     light ? light->exact_relative_irradiance(c) : 1.0, vignetting);
    if (!levels) continue;
    const double step = rms_true_step(scene, layout, te, c, light, vignetting, *levels);
    const BarOrientation along = te.orientation == BarOrientation::vertical_bars ? BarOrientation::horizontal_bars
                                                                                 : BarOrientation::vertical_bars;
    const double anisotropy = view.px_per_mm_across(c, along) / view.px_per_mm_across(c, te.orientation);
    const double signal_dn =
        dn_per_input * bar_signal_ptp(te.m, step, levels->ground, levels->signature, te.lp_per_mm);
    const double level = element_mean_level(levels->contrast, levels->ground, levels->signature);
    const double noise_dn = sensor_sigma_dn(*sensor, level);
    // Shot noise: K^2 eta mu_p electrons' worth of variance (EMVA 1288).
    const double gain = sensor->system_gain_dn_per_e();
    te.shot_fraction = gain * dn_per_input * std::max(level, 0.0) / (noise_dn * noise_dn);
    te.cnr = rose_cnr(signal_dn, pixels_per_bar(te.px_per_bar, anisotropy), noise_dn);
  }
}

}  // namespace

namespace {
// The optical and (with a sensor) the detectability limit, exactly: no
// significance test, the truth has no error.
void decide_true_limits(Truth& t, const Criterion& criterion) {
  Criterion exact = criterion;
  exact.significance_z = 0;
  t.detectability.significance_z = 0;
  for (const BarOrientation o : {BarOrientation::horizontal_bars, BarOrientation::vertical_bars}) {
    std::vector<MPoint> m;
    std::vector<CnrPoint> cnr;
    bool noise_free = true;
    for (const TruthElement& te : t.elements)
      if (te.orientation == o) {
        m.push_back({te.group, te.element, te.lp_per_mm, te.m, 0.0, te.in_view});
        cnr.push_back({te.group, te.element, te.lp_per_mm, te.cnr.value_or(0.0), 0.0, te.in_view && te.cnr, false,
                       te.shot_fraction});
        noise_free = noise_free && !te.cnr;
      }
    LimitBreakdown parts = decide_breakdown(std::move(m), std::move(cnr), exact, t.detectability);
    // Noise-free: nothing limits detection, so the optics alone decide.
    if (noise_free) parts = LimitBreakdown{parts.optical, parts.optical, LimitingFactor::optics, std::nullopt};
    const bool h = o == BarOrientation::horizontal_bars;
    (h ? t.horizontal_parts : t.vertical_parts) = parts;
    (h ? t.horizontal : t.vertical) = parts.reported();
  }
}
}  // namespace

Truth compute_truth(const Scene& scene, const TargetLayout& layout, const CameraModel& camera,
                    const DetectabilityCriterion& detectability) {
  Truth t;
  t.detectability = detectability;
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
      m *= lambert_sine_ratio(shading->lights_at(e.extent_mm().center_mm() - layout_center(layout)),
                              amp * 2 * kPi * e.lp_per_mm, horizontal ? 0 : 1, horizontal ? 1 : 0);
      te.analytic = false;
    }
    te.m = m;
    t.elements.push_back(te);
  }

  set_true_cnr(t, scene, layout, camera, view);
  decide_true_limits(t, scene.criterion);

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
                   {"in_view", e.in_view},
                   {"cnr", e.cnr && std::isfinite(*e.cnr) ? nlohmann::json(*e.cnr) : nlohmann::json()}});
  j["elements"] = els;
  j["criterion"]["detectability_k"] = t.detectability.k;
  j["limits"] = {{"horizontal_bars", breakdown_to_json(t.horizontal_parts, t.detectability)},
                 {"vertical_bars", breakdown_to_json(t.vertical_parts, t.detectability)}};
  return j;
}

}  // namespace tactres
