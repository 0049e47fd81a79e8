#include "tactres/measure/reference_patch.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "tactres/profiles/profile_sampler.h"

namespace tactres {

namespace {

// A patch misfit that only a changed curve could explain must be large
// against the noise and must shrink by this factor under the better curve;
// a profile model's own small errors (relief through a gel) never move that
// much with the encoding.
constexpr double kMuchBetterFactor = 4.0;
// A reduced chi^2 this close to 1 is a fit as good as the noise allows.
constexpr double kWithinNoiseChi2 = 2.0;

double worse_chi2(const ReferenceResult& r) {
  return std::max(r.vertical_bars.chi2_reduced, r.horizontal_bars.chi2_reduced);
}

}  // namespace

ReferenceResult fit_reference_patch(const cv::Mat& lum, const PatchScene& scene, const MeasureOptions& options) {
  ReferenceResult ref;
  ProfileSamplingOptions ps = options.sampling;
  // Half-pixel bins whatever the preset: the patch's long edges need no
  // finer ones, and at whole-pixel bins (fast) the edges' sub-pixel phase,
  // which varies along the strip, reads as misfit (reduced chi^2 ~14
  // against ~2), which sent every fast capture through the encoding check's
  // extra fits (check_transfer).
  ps.bin_px = 0.5;
  // px: across x (the scale for vertical bars); py: across y.
  const SampledProfile px = sample_strip(lum, scene.view, scene.artwork,
                                         patch_strip(scene.layout, BarOrientation::vertical_bars), ps, scene.clip_level);
  const SampledProfile py = sample_strip(lum, scene.view, scene.artwork,
                                         patch_strip(scene.layout, BarOrientation::horizontal_bars), ps, scene.clip_level);
  ref.outline_px.assign(px.outline_px.begin(), px.outline_px.end());
  ref.outline_px.insert(ref.outline_px.end(), py.outline_px.begin(), py.outline_px.end());
  if (!px.in_view || !py.in_view) {
    ref.problem = "the reference patch is not fully in view: frame the whole target";
    return ref;
  }
  if (px.pixels_clipped > px.pixels_used / 20 || py.pixels_clipped > py.pixels_used / 20) {
    ref.problem = "the reference patch is clipped (saturated or black): adjust exposure";
    return ref;
  }
  ProfileFitOptions fo;
  fo.fit_contrast = true;
  fo.fit_shape = false;
  fo.quadratic_background = true;
  std::pair<ProfileFit, ProfileFit> fits;
  if (options.signature == "albedo" || options.signature == "shading") {
    ref.signature = options.signature == "albedo" ? Signature::albedo : Signature::shading;
    fo.signature = ref.signature;
    fits = {fit_profile(px.data, fo), fit_profile(py.data, fo)};
  } else {
    // Choose the model that describes the patch across x, then fit the
    // other direction with it; across y when x shows nothing (a relief lit
    // along x).
    auto choose = [&](const ProfileData& first) {
      fo.signature = Signature::albedo;
      ProfileFit albedo = fit_profile(first, fo);
      // A printed patch that the albedo model fits to within the noise:
      // the shading model's edge-like signature cannot fit it better, and
      // its fit (a third of the patch's time) is skipped.
      if (albedo.usable && albedo.chi2_reduced <= kWithinNoiseChi2) {
        ref.signature = Signature::albedo;
        return std::make_pair(albedo, true);
      }
      fo.signature = Signature::shading;
      ProfileFit shading = fit_profile(first, fo);
      auto cost = [](const ProfileFit& f) { return f.usable ? f.chi2_reduced : 1e300; };
      ref.signature = cost(shading) < cost(albedo) ? Signature::shading : Signature::albedo;
      fo.signature = ref.signature;
      const bool chosen_usable = (ref.signature == Signature::shading ? shading : albedo).usable;
      return std::make_pair(ref.signature == Signature::shading ? shading : albedo, chosen_usable);
    };
    auto [first, usable] = choose(px.data);
    if (usable) {
      fits = {first, fit_profile(py.data, fo)};
    } else {
      const ProfileFit second = choose(py.data).first;
      fits = {fit_profile(px.data, fo), second};
    }
  }
  // A relief lit exactly along one axis shows no slope across the other:
  // that direction's fit has nothing to fit. The other direction can still
  // be measured; its elements say why the first cannot (measure.cpp).
  const bool shading = ref.signature == Signature::shading;
  if (!fits.first.usable && !fits.second.usable) {
    ref.problem = "the reference patch could not be fitted: " + fits.first.problem;
    return ref;
  }
  if ((!fits.first.usable || !fits.second.usable) && !shading) {
    ref.problem =
        "the reference patch could not be fitted: " + (fits.first.usable ? fits.second.problem : fits.first.problem);
    return ref;
  }
  if (fits.first.usable)
    ref.vertical_bars = {fits.first.contrast, fits.first.contrast_sigma, fits.first.chi2_reduced};
  if (fits.second.usable)
    ref.horizontal_bars = {fits.second.contrast, fits.second.contrast_sigma, fits.second.chi2_reduced};
  // The patch must stand out of the noise, or nothing can be normalised.
  ref.usable = ref.vertical_bars.usable() || ref.horizontal_bars.usable();
  if (!ref.usable) {
    ref.problem =
        "the reference patch shows no contrast where the layout puts it: is this the layout.json of the captured "
        "target, and is the target in focus and lit?";
    return ref;
  }
  // A patch that the model cannot describe is not where the layout puts
  // it: the fiducials matched, but the rest of the target differs. The
  // misfit must also be large against the patch's own contrast, or a
  // noise-free capture's tiny model error would trip it.
  auto relative_misfit = [](const ProfileFit& f) {
    return f.usable ? f.residual_rms / std::abs(f.contrast * f.b0) : 0.0;
  };
  const double misfit = std::max(relative_misfit(fits.first), relative_misfit(fits.second));
  if (worse_chi2(ref) > options.max_patch_chi2 && misfit > 0.25) {
    ref.usable = false;
    ref.layout_mismatch = true;
    ref.problem = fmt::format(
        "the capture does not match the layout: the reference patch is not where the layout puts it (fit chi^2 "
        "{:.0f}); measure with the layout.json of the captured target{}",
        worse_chi2(ref),
        // Without a lens model, distortion moves the patch as a wrong layout would.
        scene.have_camera ? "" : ", and give the lens's --camera model if it distorts");
  }
  return ref;
}

cv::Mat redecode(const cv::Mat& lum, const TransferCurve& from, const TransferCurve& to) {
  cv::Mat out(lum.size(), CV_32F);
  for (int y = 0; y < lum.rows; ++y) {
    const float* src = lum.ptr<float>(y);
    float* dst = out.ptr<float>(y);
    for (int x = 0; x < lum.cols; ++x) dst[x] = to.to_linear(from.to_code(src[x]));
  }
  return out;
}

TransferCheck check_transfer(const cv::Mat& lum, const TransferDecision& decision, const ReferenceResult& reference,
                             const PatchScene& scene, const MeasureOptions& options) {
  TransferCheck check;
  check.applied = decision.curve.name();
  check.best = check.applied;
  check.chi2_applied = check.chi2_best = worse_chi2(reference);
  const bool fitted = reference.usable || reference.layout_mismatch;
  if (!fitted || check.chi2_applied <= options.transfer_check_chi2) return check;
  check.checked = true;

  // Only the pixels around the patch are re-decoded for each candidate.
  std::vector<cv::Point2f> corners;
  for (const Vec2& p : reference.outline_px) corners.emplace_back(float(p.x), float(p.y));
  const cv::Rect roi = (cv::boundingRect(corners) + cv::Size(8, 8) - cv::Point(4, 4)) & cv::Rect(0, 0, lum.cols, lum.rows);
  cv::Mat work = lum.clone();
  std::vector<TransferCurve> candidates = {TransferCurve::linear(), TransferCurve::srgb()};
  for (double g : {0.5, 0.7, 1.5, 1.8, 2.0, 2.2, 2.4, 2.6, 3.0}) candidates.push_back(TransferCurve::power(g));
  std::optional<TransferCurve> best;
  for (const TransferCurve& c : candidates) {
    if (c.same_as(decision.curve)) continue;
    redecode(lum(roi), decision.curve, c).copyTo(work(roi));
    const ReferenceResult r = fit_reference_patch(work, scene, options);
    if (!(r.usable || r.layout_mismatch)) continue;
    if (worse_chi2(r) < check.chi2_best) {
      check.chi2_best = worse_chi2(r);
      best = c;
    }
  }
  if (!best || check.chi2_best * kMuchBetterFactor > check.chi2_applied) return check;
  check.best = best->name();
  check.mismatch = true;
  const bool standard = best->kind != TransferCurve::Kind::power;
  if (decision.guessed && standard) {
    check.switch_to = *best;
    check.message = fmt::format(
        "the file has no colour tag and {} was assumed, but the reference patch fits as if the file were "
        "{}-encoded (patch chi^2 {:.3g} vs {:.3g}): measured as {}; pass {} or {} to choose",
        check.applied, check.best, check.chi2_best, check.chi2_applied, check.best, best->option(),
        decision.curve.option());
  } else {
    check.message = fmt::format(
        "the profiles fit as if the file were {}-encoded, not {} (reference patch chi^2 {:.3g} vs {:.3g}); use {}",
        check.best, check.applied, check.chi2_best, check.chi2_applied, best->option());
  }
  return check;
}

}  // namespace tactres
