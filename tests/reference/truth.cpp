// The reference renderer's own truth. Its chain is a Gaussian blur of
// sigma_mm in the target plane followed by point sampling, so every element's
// modulation is m(f) = exp(-2 pi^2 sigma^2 f^2) exactly, whatever the pose or
// lens: there is no pixel aperture. (For relief, the image is a directional
// derivative of the blurred height; the derivative is the signature, and the
// blur's transfer is still the m above.)
#include <algorithm>
#include <cmath>
#include <map>

#include "reference_renderer.h"

namespace reference {
namespace {

bool projects_inside(const Camera& camera, const RigidTransform& T, double x_mm, double y_mm) {
  const Vec3 p = T.apply({x_mm, y_mm, 0});
  if (p[2] <= 0) return false;
  const Vec2 q = camera.project(p);
  return q[0] >= 0 && q[1] >= 0 && q[0] <= camera.width_px() - 1 && q[1] <= camera.height_px() - 1;
}

TruthLimit limit_of(std::vector<const TruthElement*> elements, double sigma_mm, double threshold) {
  std::sort(elements.begin(), elements.end(),
            [](const TruthElement* a, const TruthElement* b) { return a->lp_per_mm < b->lp_per_mm; });
  TruthLimit L;
  L.interpolated_lp_per_mm = interpolated_limit_lp_per_mm(sigma_mm, threshold);
  for (const TruthElement* e : elements) {
    if (e->m < threshold) break;
    L.resolved_any = true;
    L.group = e->group;
    L.element = e->element;
    L.lp_per_mm = e->lp_per_mm;
  }
  L.beyond_finest = !elements.empty() && elements.back()->m >= threshold;
  return L;
}

nlohmann::json limit_json(const TruthLimit& L) {
  return {{"resolved_any", L.resolved_any},
          {"group", L.group},
          {"element", L.element},
          {"lp_per_mm", L.lp_per_mm},
          {"interpolated_lp_per_mm", L.interpolated_lp_per_mm},
          {"beyond_finest", L.beyond_finest}};
}

}  // namespace

double m_true(double sigma_mm, double lp_per_mm) {
  return std::exp(-2 * M_PI * M_PI * sigma_mm * sigma_mm * lp_per_mm * lp_per_mm);
}

double interpolated_limit_lp_per_mm(double sigma_mm, double threshold) {
  return std::sqrt(std::log(1 / threshold) / (2 * M_PI * M_PI)) / sigma_mm;
}

const TruthElement* Truth::find(int group, int element, const std::string& orientation) const {
  for (const TruthElement& e : elements)
    if (e.group == group && e.element == element && e.orientation == orientation) return &e;
  return nullptr;
}

Truth make_truth(const Layout& layout, const Camera& camera, const Pose& pose, double sigma_mm, double threshold) {
  Truth truth;
  truth.sigma_mm = sigma_mm;
  truth.threshold = threshold;
  const RigidTransform T = camera_from_target(pose, layout.width_mm, layout.height_mm);
  for (const LayoutElement& le : layout.elements) {
    TruthElement e;
    e.group = le.group;
    e.element = le.element;
    e.orientation = le.orientation();
    e.lp_per_mm = le.lp_per_mm;
    e.m = m_true(sigma_mm, le.lp_per_mm);
    const Vec2 c_mm = le.center_mm();
    // Horizontal bars resolve detail along y, vertical bars along x.
    const Vec2 across = le.horizontal_bars ? Vec2{0, 1} : Vec2{1, 0};
    e.px_per_bar = le.bar_width_mm * px_per_mm_along(camera, T, c_mm, across);
    e.px_per_bar_along = le.bar_width_mm * px_per_mm_along(camera, T, c_mm, Vec2{across[1], across[0]});
    e.center_px = camera.project(T.apply({c_mm[0], c_mm[1], 0}));
    e.in_view = true;
    for (const RectMm& b : le.bars_mm)
      for (double x : {b.x0_mm, b.x1_mm})
        for (double y : {b.y0_mm, b.y1_mm}) e.in_view = e.in_view && projects_inside(camera, T, x, y);
    truth.elements.push_back(e);
  }
  std::map<std::string, std::vector<const TruthElement*>> by_orientation;
  for (const TruthElement& e : truth.elements) by_orientation[e.orientation].push_back(&e);
  truth.horizontal_bars = limit_of(by_orientation["horizontal_bars"], sigma_mm, threshold);
  truth.vertical_bars = limit_of(by_orientation["vertical_bars"], sigma_mm, threshold);
  return truth;
}

double detectability_limit_lp_per_mm(const Truth& truth, const std::string& orientation, double level_step,
                                     double noise_sigma, double k) {
  std::vector<const TruthElement*> els;
  for (const TruthElement& e : truth.elements)
    if (e.orientation == orientation) els.push_back(&e);
  std::sort(els.begin(), els.end(), [](const TruthElement* a, const TruthElement* b) { return a->lp_per_mm < b->lp_per_mm; });
  auto cnr = [&](const TruthElement* e) {
    return 4 / M_PI * e->m * std::abs(level_step) * std::sqrt(5 * e->px_per_bar * e->px_per_bar_along) / noise_sigma;
  };
  for (size_t i = 0; i + 1 < els.size(); ++i) {
    if (cnr(els[i]) < k) return 0;  // nothing detectable before it
    const double c1 = cnr(els[i + 1]);
    if (c1 >= k) continue;
    const double l0 = std::log(cnr(els[i])), l1 = std::log(std::max(c1, 1e-12)), lk = std::log(k);
    const double s0 = els[i]->lp_per_mm * els[i]->lp_per_mm, s1 = els[i + 1]->lp_per_mm * els[i + 1]->lp_per_mm;
    return std::sqrt(s0 + (l0 - lk) / (l0 - l1) * (s1 - s0));
  }
  return 0;
}

nlohmann::json truth_json(const Truth& truth, const Pose& pose, const Scene& scene, const Camera& camera,
                          const Layout& layout) {
  const RigidTransform T = camera_from_target(pose, layout.width_mm, layout.height_mm);
  const Vec3 r = rodrigues_of(T.rotation);
  nlohmann::json elements = nlohmann::json::array();
  for (const TruthElement& e : truth.elements)
    elements.push_back({{"group", e.group},
                        {"element", e.element},
                        {"orientation", e.orientation},
                        {"lp_per_mm", e.lp_per_mm},
                        {"m", e.m},
                        {"px_per_bar", e.px_per_bar},
                        {"center_px", {e.center_px[0], e.center_px[1]}},
                        {"in_view", e.in_view}});
  return {
      {"schema", "tactres.reference_truth/1"},
      {"renderer", "tests/reference (independent of tactres' simulator)"},
      {"model", scene.mode == "relief" ? "I = level + gain_per_slope * l . grad(G_sigma * h), point-sampled"
                                       : "I = ground + (ink - ground) * (G_sigma * ink), point-sampled"},
      {"mode", scene.mode},
      {"sigma_mm", truth.sigma_mm},
      {"m_of_f", "exp(-2 pi^2 sigma_mm^2 f^2)"},
      {"criterion", {{"threshold", truth.threshold}}},
      {"camera", {{"lensmodel", camera.lensmodel_name()}, {"intrinsics", camera.intrinsics()},
                  {"imagersize", {camera.width_px(), camera.height_px()}}}},
      {"pose", {{"distance_mm", pose.distance_mm}, {"roll_deg", pose.roll_deg}, {"tilt_deg", pose.tilt_deg},
                {"mirrored", pose.mirrored}, {"shift_mm", {pose.shift_mm[0], pose.shift_mm[1]}},
                {"rt_camera_from_target", {r[0], r[1], r[2], T.translation_mm[0], T.translation_mm[1],
                                           T.translation_mm[2]}}}},
      {"noise", {{"snr_db", scene.snr_db}, {"sigma", noise_sigma(layout, scene)}, {"seed", scene.seed},
                 {"level_step", level_step(layout, scene)}}},
      {"elements", elements},
      {"limits", {{"horizontal_bars", limit_json(truth.horizontal_bars)},
                  {"vertical_bars", limit_json(truth.vertical_bars)}}},
  };
}

}  // namespace reference
