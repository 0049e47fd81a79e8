#include "tactres/measure/gain_field.h"

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>

namespace tactres {

namespace {
// Every estimate of the step carries the profile model's own error beyond
// its fit sigma (a noise-free render's estimates scatter by ~1-2 % between
// the patch and the bars): 3 % of the patch's step is added in quadrature,
// so that noise-free fits do not pretend to pin the plane to 1e-5.
constexpr double kModelFloor = 0.03;
// Coarse: bins are flat at >= 4 px per bar (as for the noise pool), and the
// fitted transfer at the element's own frequency says its bars are many
// blur widths wide, so the fitted step is not confused with m.
constexpr double kCoarsePxPerBar = 4.0;
constexpr double kCoarseTransfer = 0.6;
// A gradient is real when it stands 3 sigma out of its own error.
constexpr double kGradientSignificance = 9.0;  // chi^2 of (gx, gy), 3 sigma

}  // namespace

LevelStep GainField::at(Vec2 p, const LevelStep& patch) const {
  if (!plane) return patch;
  const double d[3] = {1.0, p.x - origin_mm.x, p.y - origin_mm.y};
  const auto& C = covariance;  // (0,0) (0,1) (0,2) (1,1) (1,2) (2,2)
  const double var = d[0] * d[0] * C[0] + d[1] * d[1] * C[3] + d[2] * d[2] * C[5] +
                     2 * (d[0] * d[1] * C[1] + d[0] * d[2] * C[2] + d[1] * d[2] * C[4]);
  return {contrast + gradient_x_per_mm * d[1] + gradient_y_per_mm * d[2], std::sqrt(std::max(var, 0.0) + misfit_var),
          chi2_reduced};
}

GainField fit_gain_field(const std::vector<GainSample>& samples, Vec2 patch_center_mm, const LevelStep& patch,
                         const std::vector<Vec2>& measured_at_mm) {
  GainField f;
  f.origin_mm = patch_center_mm;
  f.samples = static_cast<int>(samples.size());
  if (samples.size() < 4) return f;
  double scale = patch.usable() ? std::abs(patch.contrast) : 0.0;
  for (const GainSample& s : samples) scale = std::max(scale, std::abs(s.contrast));
  if (!(scale > 0)) return f;
  // A sample's variance: its fit's, plus the profile model's own scatter.
  const auto variance = [&](const GainSample& s) {
    return s.contrast_sigma * s.contrast_sigma + kModelFloor * kModelFloor * scale * scale;
  };
  cv::Matx33d normal = cv::Matx33d::zeros();
  cv::Vec3d rhs(0, 0, 0);
  for (const GainSample& s : samples) {
    const double w = 1.0 / variance(s);
    const cv::Vec3d d(1.0, s.at_mm.x - patch_center_mm.x, s.at_mm.y - patch_center_mm.y);
    normal += w * d * d.t();
    rhs += w * s.contrast * d;
  }
  // Both axes spanned: otherwise the plane is not determined.
  if (cv::determinant(normal) <= 1e-9 * normal(0, 0) * normal(1, 1) * normal(2, 2)) return f;
  const cv::Matx33d cov0 = normal.inv(cv::DECOMP_CHOLESKY);
  const cv::Vec3d p = cov0 * rhs;
  double chi2 = 0, mean_var = 0;
  for (const GainSample& s : samples) {
    const double w = 1.0 / variance(s);
    const double r = s.contrast - (p[0] + p[1] * (s.at_mm.x - patch_center_mm.x) + p[2] * (s.at_mm.y - patch_center_mm.y));
    chi2 += w * r * r;
    mean_var += variance(s) / samples.size();
  }
  const double chi2_reduced = chi2 / (samples.size() - 3);
  // A plane that misfits more than the errors allow (the field is curved)
  // widens its own errors (never narrows them).
  const cv::Matx33d cov = std::max(1.0, chi2_reduced) * cov0;
  GainField plane = f;
  plane.plane = true;
  plane.contrast = p[0];
  plane.gradient_x_per_mm = p[1];
  plane.gradient_y_per_mm = p[2];
  plane.covariance = {cov(0, 0), cov(0, 1), cov(0, 2), cov(1, 1), cov(1, 2), cov(2, 2)};
  plane.chi2_reduced = chi2_reduced;
  plane.misfit_var = std::max(0.0, chi2_reduced - 1) * mean_var;
  const double reference = patch.usable() ? patch.contrast : p[0];
  for (const Vec2& m : measured_at_mm)
    plane.spread = std::max(plane.spread, std::abs(plane.at(m, patch).contrast / reference - 1));
  // The gradient's significance: g^T C_g^-1 g over its 2 x 2 covariance.
  const cv::Matx22d cg(cov(1, 1), cov(1, 2), cov(2, 1), cov(2, 2));
  const cv::Vec2d g(p[1], p[2]);
  const double significance = (g.t() * cg.inv(cv::DECOMP_SVD) * g)(0);
  // Without a usable patch there is no uniform step to fall back on.
  if (patch.usable() && (plane.spread <= kUniformTolerance || significance < kGradientSignificance)) return f;
  return plane;
}

void estimate_gain_fields(const std::vector<ElementJob>& jobs,
                          const std::vector<std::vector<SampledProfile>>& profiles, const TargetLayout& layout,
                          ReferenceResult& reference) {
  const Vec2 patch_center = layout.reference_patch_mm.center_mm();
  for (const BarOrientation o : {BarOrientation::horizontal_bars, BarOrientation::vertical_bars}) {
    const LevelStep& patch = reference.step(o);
    std::vector<GainSample> samples;
    if (patch.usable()) samples.push_back({patch_center, patch.contrast, patch.contrast_sigma});
    std::vector<Vec2> measured_at;
    for (size_t j = 0; j < jobs.size(); ++j) {
      const ElementResult& e = jobs[j].element;
      if (e.orientation != o) continue;
      const Vec2 at = jobs[j].placements.front().strip.center_mm;
      measured_at.push_back(at);
      const SampledProfile& sp = profiles[j].front();
      if (e.px_per_bar < kCoarsePxPerBar || !sp.in_view || sp.pixels_clipped > sp.pixels_used / 50) continue;
      ProfileFitOptions fo;
      fo.signature = Signature::shading;
      fo.fit_contrast = true;
      fo.fit_shape = false;
      const ProfileFit fit = jobs[j].prepare ? fit_profile(jobs[j].prepare(sp.data, fo), fo) : fit_profile(sp.data, fo);
      if (!fit.usable || !(fit.transfer(e.lp_per_mm) >= kCoarseTransfer) || !std::isfinite(fit.contrast_sigma))
        continue;
      samples.push_back({at, fit.contrast, fit.contrast_sigma});
    }
    (o == BarOrientation::horizontal_bars ? reference.horizontal_field : reference.vertical_field) =
        fit_gain_field(samples, patch_center, patch, measured_at);
  }
}

}  // namespace tactres
