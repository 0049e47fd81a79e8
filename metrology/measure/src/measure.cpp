#include "tactres/measure/measure.h"
#include "tactres/util/stopwatch.h"
#include "tactres/locate/rectified_search.h"
#include "tactres/measure/reference_patch.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <tuple>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "tactres/measure/element_grading.h"
#include "tactres/camera/target_view.h"
#include "tactres/targets/coverage.h"

namespace tactres {

const char* to_string(ElementStatus s) {
  switch (s) {
    case ElementStatus::ok: return "ok";
    case ElementStatus::low_signal: return "low_signal";
    case ElementStatus::clipped: return "clipped";
    case ElementStatus::aliased: return "aliased";
    case ElementStatus::below_sampling_limit: return "below_sampling_limit";
    case ElementStatus::out_of_view: return "out_of_view";
    case ElementStatus::fit_failed: return "fit_failed";
  }
  return "fit_failed";
}

const char* to_string(Preset p) {
  return p == Preset::fast ? "fast" : p == Preset::balanced ? "balanced" : "precise";
}

Preset preset_from_string(const std::string& s) {
  if (s == "fast") return Preset::fast;
  if (s == "balanced") return Preset::balanced;
  if (s == "precise") return Preset::precise;
  throw std::invalid_argument("unknown preset '" + s + "': use fast, balanced or precise");
}

MeasureOptions MeasureOptions::for_preset(Preset p) {
  // What each preset buys (README, "Presets"; figures from `tactres bench`):
  // fast: whole-pixel bins and a light pose model, still fitting the PSF's
  // shape (a Gaussian-only fit cost little time but its errors were three
  // times larger and its error bars covered the truth half the time);
  // precise: eighth-pixel bins and a finely sampled disc outline in the pose
  // model.
  struct Settings {
    double bin_px;
    bool fit_psf_shape;
    int pose_boundary_points;
    double max_bins_per_bar;
  };
  static constexpr Settings kSettings[] = {
      {1.0, true, 16, 6},      // fast
      {0.25, true, 32, 8},     // balanced
      {0.125, true, 96, 16},   // precise
  };
  const Settings& s = kSettings[static_cast<int>(p)];
  MeasureOptions o;
  o.preset = p;
  o.sampling.bin_px = s.bin_px;
  o.fit_psf_shape = s.fit_psf_shape;
  o.pose_boundary_points = s.pose_boundary_points;
  o.max_bins_per_bar = s.max_bins_per_bar;
  return o;
}

void MeasureOptions::validate() const {
  sampling.validate();
  criterion.validate();
  if (!(min_px_per_bar >= 0.5 && min_px_per_bar <= 20))
    throw std::invalid_argument("--min-px-per-bar must be in [0.5, 20]");
  if (!(max_m_sigma > 0 && max_m_sigma <= 1)) throw std::invalid_argument("max m sigma must be in (0, 1]");
  if (!(aliasing_chi2 > 1)) throw std::invalid_argument("aliasing chi^2 threshold must be > 1");
  if (!(pose_boundary_points >= 8 && pose_boundary_points <= 1024))
    throw std::invalid_argument("pose boundary points must be in [8, 1024]");
  if (!(max_bins_per_bar >= 2 && max_bins_per_bar <= 64))
    throw std::invalid_argument("max bins per bar must be in [2, 64]");
  if (signature != "auto" && signature != "albedo" && signature != "shading")
    throw std::invalid_argument("--signature must be auto, albedo or shading");
}

namespace {


// A copy with masked (NaN) pixels filled by the median, for OpenCV's blob
// search, which has no notion of "no data".
cv::Mat filled_for_detection(const cv::Mat& lum) {
  std::vector<float> finite;
  finite.reserve(lum.total() / 16 + 1);
  for (int y = 0; y < lum.rows; y += 4)
    for (int x = 0; x < lum.cols; x += 4)
      if (std::isfinite(lum.at<float>(y, x))) finite.push_back(lum.at<float>(y, x));
  if (finite.empty()) return lum.clone();
  std::nth_element(finite.begin(), finite.begin() + finite.size() / 2, finite.end());
  const float median = finite[finite.size() / 2];
  cv::Mat out = lum.clone();
  out.forEach<float>([&](float& v, const int*) {
    if (!std::isfinite(v)) v = median;
  });
  return out;
}

}  // namespace

Measurement measure_capture(const LoadedImage& image, const TargetLayout& layout, const CameraModel* camera,
                            const MeasureOptions& options) {
  options.validate();
  Measurement M;
  M.image_width = image.width;
  M.image_height = image.height;
  const cv::Mat& lum_in = image.luminance;
  if (camera) camera->check_image_size(image.width, image.height);

  // Saturation: a capture that is mostly clipped cannot be measured.
  if (image.saturation_level > 0) {
    const double clip = image.saturation_level * 0.9999;
    long long clipped = 0, finite = 0;
    for (int y = 0; y < lum_in.rows; ++y) {
      const float* r = lum_in.ptr<float>(y);
      for (int x = 0; x < lum_in.cols; ++x)
        if (std::isfinite(r[x])) {
          ++finite;
          clipped += r[x] >= clip ? 1 : 0;
        }
    }
    if (finite > 0 && clipped > finite / 2) {
      M.problem = fmt::format(
          "the capture is saturated: {:.0f}% of the pixels are at the clip level; reduce exposure or "
          "illumination and capture again",
          100.0 * clipped / finite);
      return M;
    }
  }

  Stopwatch t;
  // (A copy only when pixels are masked: it costs ~1 ms per megapixel.)
  const cv::Mat detection_image = cv::checkRange(lum_in) ? lum_in : filled_for_detection(lum_in);
  PoseOptions po;
  po.boundary_points = options.pose_boundary_points;
  auto observations_of = [&](const FiducialSearchResult& found) {
    std::vector<DiscObservation> discs = disc_observations(layout.fiducials);
    for (size_t i = 0; i < discs.size(); ++i)
      for (const FiducialDetection& d : found.discs)
        if (d.id == layout.fiducials[i].id) discs[i].centroid_px = d.centroid_px;
    return discs;
  };
  // A strongly distorting lens bends the disc pattern away from a plane
  // homography. With a lens model, a failed search of the capture's coarse
  // copy is followed by a search of a rectified copy, where the pattern is
  // a homography again, and the pose is fitted through that copy's pinhole,
  // which shares the lens's rays. Only if that finds no usable pose does
  // the costly full-resolution search of the capture run.
  const bool distorting = camera && !camera->is_pinhole();
  FiducialSearchOptions first;
  first.coarse_only = distorting;
  M.fiducials = find_fiducials(detection_image, layout, first);
  std::optional<CameraModel> search_camera;  // the rectified view's pinhole, if used
  if (!M.fiducials.found && distorting) {
    std::optional<RectifiedSearch> rectified = find_fiducials_rectified(detection_image, layout, *camera);
    if (rectified && rectified->fiducials.found) {
      PoseResult pose = fit_pose(rectified->pinhole, observations_of(rectified->fiducials), po);
      if (pose.usable) {
        M.fiducials = rectified->fiducials;
        M.pose = pose;
        search_camera = rectified->pinhole;
      }
    }
    if (!search_camera) M.fiducials = find_fiducials(detection_image, layout);
  }
  M.stage_seconds.push_back({"locate_fiducials", t.seconds()});
  if (!M.fiducials.found) {
    M.problem = M.fiducials.problem.empty() ? "no target found" : M.fiducials.problem;
    return M;
  }

  t.restart();
  const std::vector<DiscObservation> discs = observations_of(M.fiducials);
  std::optional<CameraModel> fitted;
  if (search_camera) {
    // Fitted above, with the search (the time counts there).
    M.camera_source = camera->source();
    M.distortion_corrected = true;
    // Report the discs where they are in the capture.
    for (FiducialDetection& d : M.fiducials.discs)
      if (auto p = unrectify_point(d.centroid_px, *camera, *search_camera)) d.centroid_px = *p;
  } else if (camera) {
    M.pose = fit_pose(*camera, discs, po);
    M.camera_source = camera->source();
    M.distortion_corrected = true;
  } else {
    PinholePoseOptions pp;
    pp.pose = po;
    PinholePoseResult r = fit_pinhole_and_pose(image.width, image.height, discs, pp);
    M.pose = r.pose;
    fitted = r.camera;
    M.camera_source = "pinhole fitted from the fiducials (no camera model: distortion not corrected)";
    M.distortion_corrected = false;
  }
  M.stage_seconds.push_back({"pose", t.seconds()});
  if (!M.pose.usable || (!camera && !fitted)) {
    M.problem = "the fiducials do not fit the layout (" + M.pose.problem +
                "): is this the layout of the captured target, and the right camera model?";
    return M;
  }
  if (M.pose.rms_px > 2.0) {
    M.problem = fmt::format(
        "the fiducials fit the layout poorly (reprojection RMS {:.2f} px): wrong layout, wrong camera "
        "model, or a strongly deformed target",
        M.pose.rms_px);
    return M;
  }
  const CameraModel& cam = camera ? *camera : *fitted;
  const TargetView view(cam, M.pose.rt_camera_from_target_mm);
  const ArtworkIndex index(layout.artwork, 0.0);
  const double clip_level = image.saturation_level;

  const TargetView::Nyquist nyq = view.nyquist({0.5 * layout.width_mm, 0.5 * layout.height_mm});
  M.nyquist_h_lp_per_mm = nyq.horizontal_bars_lp_per_mm;
  M.nyquist_v_lp_per_mm = nyq.vertical_bars_lp_per_mm;

  // Reference patch: the contrast scale per direction, the signature
  // (printed bars vs relief through a gel) when it is not given, and the
  // check that the pixels were decoded with the curve the patch fits.
  t.restart();
  M.transfer = image.transfer;
  cv::Mat redecoded;  // the capture under a better curve, when one replaces a guess
  const PatchScene patch_scene{view, layout, index, clip_level, camera != nullptr};
  M.reference = fit_reference_patch(lum_in, patch_scene, options);
  M.transfer_check = check_transfer(lum_in, image.transfer, M.reference, patch_scene, options);
  if (M.transfer_check.switch_to) {
    redecoded = redecode(lum_in, image.transfer.curve, *M.transfer_check.switch_to);
    M.transfer = {*M.transfer_check.switch_to,
                  image.transfer.reason + "; switched: the reference patch fits " +
                      M.transfer_check.switch_to->name() + " far better",
                  false};
    M.reference = fit_reference_patch(redecoded, patch_scene, options);
  }
  if (!M.transfer_check.message.empty()) M.warnings.push_back(M.transfer_check.message);
  const cv::Mat& lum = redecoded.empty() ? lum_in : redecoded;
  // A patch the model cannot describe under this curve, when another curve
  // describes it: the encoding is wrong, not the layout. Measure, and say so.
  const bool encoding_mismatch = M.transfer_check.mismatch && !M.transfer_check.switch_to;
  if (encoding_mismatch && M.reference.layout_mismatch) {
    M.reference.usable = true;
    M.reference.layout_mismatch = false;
    M.reference.problem.clear();
  }
  const ReferenceResult& ref = M.reference;
  M.stage_seconds.push_back({"reference_patch", t.seconds()});
  if (!ref.usable) {
    M.problem = ref.problem;
    return M;
  }

  // Elements.
  t.restart();
  double sample_s = 0, fit_s = 0;
  // Warm start per orientation from the last good fit (coarse to fine).
  std::pair<double, double> last_lsf[2] = {{0, 0}, {0, 0}};
  for (const ElementLayout& e : layout.elements) {
    ElementResult r;
    r.group = e.group;
    r.element = e.element;
    r.orientation = e.orientation;
    r.lp_per_mm = e.lp_per_mm;
    const bool across_x = e.orientation == BarOrientation::vertical_bars;
    Stopwatch ts;
    ProfileSamplingOptions so = options.sampling;
    const Strip strip = element_strip(e, so);
    r.px_per_bar = e.bar_width_mm * view.px_per_mm(strip.center_mm, across_x);
    // Coarse elements need no quarter-pixel bins: cap the bins per bar.
    so.bin_px = std::max(so.bin_px, r.px_per_bar / options.max_bins_per_bar);
    const SampledProfile sp = sample_strip(lum, view, layout, index, strip, so, clip_level);
    sample_s += ts.seconds();
    ProfileFitOptions fo;
    fo.signature = ref.signature;
    fo.fit_contrast = false;
    fo.contrast = across_x ? ref.contrast_x : ref.contrast_y;
    fo.fit_shape = options.fit_psf_shape;
    if (!ref.has_contrast(across_x)) {
      // The patch shows nothing across this direction (a relief lit along
      // these bars): there is no scale to measure m against.
      r.status = ElementStatus::low_signal;
      r.outline_px = sp.outline_px;
      r.outline_valid = sp.in_view;
      r.note = "the reference patch shows no contrast across these bars (a relief lit along them?): m cannot be "
               "scaled";
      M.elements.push_back(r);
      continue;
    }
    fit_s += grade_element(r, sp, fo, across_x ? ref.contrast_x_sigma : ref.contrast_y_sigma, options,
                           last_lsf[across_x], {}, encoding_mismatch);
    M.elements.push_back(r);
  }
  M.stage_seconds.push_back({"profiles", sample_s});
  M.stage_seconds.push_back({"fits", fit_s});

  // Decide.
  t.restart();
  decide_limits(M, options.criterion, false);
  M.stage_seconds.push_back({"decide", t.seconds()});
  M.usable = true;
  return M;
}

}  // namespace tactres
