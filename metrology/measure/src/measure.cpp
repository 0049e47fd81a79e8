#include "tactres/measure/measure.h"
#include "tactres/util/stopwatch.h"
#include "tactres/locate/rectified_search.h"
#include "tactres/measure/reference_patch.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <tuple>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "tactres/measure/element_pipeline.h"
#include "tactres/measure/gain_field.h"
#include "tactres/camera/target_view.h"
#include "tactres/targets/coverage.h"

namespace tactres {

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

// The share of finite pixels at the clip level; a capture that is mostly
// clipped cannot be measured. Counted on every 4th pixel of every 4th row:
// a decision at one half needs no more, and a live frame cannot spare the
// full scan.
double clipped_share(const LoadedImage& image) {
  if (!(image.saturation_level > 0)) return 0;
  const cv::Mat& lum = image.luminance;
  const double clip = image.saturation_level * 0.9999;
  long long clipped = 0, finite = 0;
  for (int y = 0; y < lum.rows; y += 4) {
    const float* r = lum.ptr<float>(y);
    for (int x = 0; x < lum.cols; x += 4)
      if (std::isfinite(r[x])) {
        ++finite;
        clipped += r[x] >= clip ? 1 : 0;
      }
  }
  return finite > 0 ? double(clipped) / finite : 0;
}

std::vector<DiscObservation> observations_of(const TargetLayout& layout, const FiducialSearchResult& found) {
  std::vector<DiscObservation> discs = disc_observations(layout.fiducials);
  for (size_t i = 0; i < discs.size(); ++i)
    for (const FiducialDetection& d : found.discs)
      if (d.id == layout.fiducials[i].id) discs[i].centroid_px = d.centroid_px;
  return discs;
}

// The box around the found discs (x0, y0, x1, y1), px.
std::array<double, 4> disc_box(const FiducialSearchResult& found) {
  std::array<double, 4> box{1e300, 1e300, -1e300, -1e300};
  for (const FiducialDetection& d : found.discs) {
    const double r = std::sqrt(std::max(d.area_px, 0.0) / 3.14159265358979);
    box[0] = std::min(box[0], d.centroid_px.x - r);
    box[1] = std::min(box[1], d.centroid_px.y - r);
    box[2] = std::max(box[2], d.centroid_px.x + r);
    box[3] = std::max(box[3], d.centroid_px.y + r);
  }
  return box;
}

// The fiducials searched only near where the frame before saw them: the
// track's box grown by `margin` of its size on every side, as a view into
// the image (no copy). Coordinates come back in the whole image's pixels.
FiducialSearchResult find_near_track(const cv::Mat& detection_image, const TargetLayout& layout,
                                     const LayoutTrack& track, double margin, bool coarse_only) {
  const std::array<double, 4> box = disc_box(track.fiducials);
  const double w = box[2] - box[0], h = box[3] - box[1];
  const double grow = margin * std::max(w, h);
  const int x0 = std::clamp(int(std::floor(box[0] - grow)), 0, detection_image.cols - 1);
  const int y0 = std::clamp(int(std::floor(box[1] - grow)), 0, detection_image.rows - 1);
  const int x1 = std::clamp(int(std::ceil(box[2] + grow)) + 1, x0 + 1, detection_image.cols);
  const int y1 = std::clamp(int(std::ceil(box[3] + grow)) + 1, y0 + 1, detection_image.rows);
  FiducialSearchOptions o;
  o.coarse_only = coarse_only && std::min(x1 - x0, y1 - y0) >= 400;
  FiducialSearchResult r = find_fiducials(detection_image(cv::Rect(x0, y0, x1 - x0, y1 - y0)), layout, o);
  for (FiducialDetection& d : r.discs) d.centroid_px = {d.centroid_px.x + x0, d.centroid_px.y + y0};
  // image = T(x0, y0) * crop_from_target: rows 0 and 1 gain x0, y0 times row 2.
  std::array<double, 9>& H = r.image_from_target;
  for (int c = 0; c < 3; ++c) {
    H[c] += x0 * H[6 + c];
    H[3 + c] += y0 * H[6 + c];
  }
  return r;
}


// Finds the fiducials into M.fiducials. A strongly distorting lens bends
// the disc pattern away from a plane homography. With a lens model, a
// failed search of the capture's coarse copy is followed by a search of a
// rectified copy, where the pattern is a homography again, and the pose is
// fitted through that copy's pinhole, which shares the lens's rays (into
// M.pose; that pinhole is returned). Only if that finds no usable pose does
// the costly full-resolution search of the capture run.
std::optional<CameraModel> find_target(const cv::Mat& detection_image, const TargetLayout& layout,
                                       const CameraModel* camera, const PoseOptions& po, Measurement& M) {
  const bool distorting = camera && !camera->is_pinhole();
  FiducialSearchOptions first;
  first.coarse_only = distorting;
  M.fiducials = find_fiducials(detection_image, layout, first);
  if (M.fiducials.found || !distorting) return std::nullopt;
  std::optional<RectifiedSearch> rectified = find_fiducials_rectified(detection_image, layout, *camera);
  if (rectified && rectified->fiducials.found) {
    PoseResult pose = fit_pose(rectified->pinhole, observations_of(layout, rectified->fiducials), po);
    if (pose.usable) {
      M.fiducials = rectified->fiducials;
      M.pose = pose;
      return rectified->pinhole;
    }
  }
  M.fiducials = find_fiducials(detection_image, layout);
  return std::nullopt;
}

// The pose from the found fiducials into M.pose (unless the rectified
// search already fitted it), and the camera the target is seen through:
// the given model, or a pinhole fitted here when there is none (returned).
std::optional<CameraModel> fit_target_pose(const LoadedImage& image, const TargetLayout& layout,
                                           const CameraModel* camera, const std::optional<CameraModel>& search_camera,
                                           const PoseOptions& po, const LayoutTrack* track, Measurement& M) {
  if (search_camera) {
    M.camera_source = camera->source();
    M.distortion_corrected = true;
    // Report the discs where they are in the capture.
    for (FiducialDetection& d : M.fiducials.discs)
      if (auto p = unrectify_point(d.centroid_px, *camera, *search_camera)) d.centroid_px = *p;
    return std::nullopt;
  }
  const std::vector<DiscObservation> discs = observations_of(layout, M.fiducials);
  if (!camera && track && track->fitted_camera) {
    // A live sequence keeps the pinhole it fitted on a frame measured from
    // scratch: the lens does not change between frames, the pose does.
    M.pose = fit_pose(*track->fitted_camera, discs, po);
    M.camera_source = "pinhole fitted from the fiducials (no camera model: distortion not corrected)";
    M.distortion_corrected = false;
    return track->fitted_camera;
  }
  if (camera) {
    M.pose = fit_pose(*camera, discs, po);
    M.camera_source = camera->source();
    M.distortion_corrected = true;
    return std::nullopt;
  }
  PinholePoseOptions pp;
  pp.pose = po;
  PinholePoseResult r = fit_pinhole_and_pose(image.width, image.height, discs, pp);
  M.pose = r.pose;
  M.camera_source = "pinhole fitted from the fiducials (no camera model: distortion not corrected)";
  M.distortion_corrected = false;
  return r.camera;
}

// The reference patch under the capture's transfer curve, checked against
// other curves (reference_patch.h), into M.reference / M.transfer /
// M.transfer_check. Returns the capture re-decoded when a better curve
// replaced a guess (empty otherwise), and whether a global encoding
// mismatch remains.
std::pair<cv::Mat, bool> fit_reference(const LoadedImage& image, const PatchScene& scene,
                                       const MeasureOptions& options, Measurement& M) {
  const cv::Mat& lum_in = image.luminance;
  M.transfer = image.transfer;
  cv::Mat redecoded;
  M.reference = fit_reference_patch(lum_in, scene, options);
  M.transfer_check = check_transfer(lum_in, image.transfer, M.reference, scene, options);
  if (M.transfer_check.switch_to) {
    redecoded = redecode(lum_in, image.transfer.curve, *M.transfer_check.switch_to);
    M.transfer = {*M.transfer_check.switch_to,
                  image.transfer.reason + "; switched: the reference patch fits " +
                      M.transfer_check.switch_to->name() + " far better",
                  false};
    M.reference = fit_reference_patch(redecoded, scene, options);
  }
  if (!M.transfer_check.message.empty()) M.warnings.push_back(M.transfer_check.message);
  // A patch the model cannot describe under this curve, when another curve
  // describes it: the encoding is wrong, not the layout. Measure, and say so.
  const bool encoding_mismatch = M.transfer_check.mismatch && !M.transfer_check.switch_to;
  if (encoding_mismatch && M.reference.layout_mismatch) {
    M.reference.usable = true;
    M.reference.layout_mismatch = false;
    M.reference.problem.clear();
  }
  return {redecoded, encoding_mismatch};
}

// One job per layout element the plan fits, all through the target view,
// coarse to fine; `index` receives each job's layout element.
std::vector<ElementJob> layout_jobs(const TargetLayout& layout, const TargetView& view,
                                    const IndexedArtwork& artwork, const MeasureOptions& options,
                                    const FramePlan& plan, std::vector<size_t>& index) {
  std::vector<ElementJob> jobs;
  for (size_t i = 0; i < layout.elements.size(); ++i) {
    if (plan.fit_element && plan.carried && !plan.fit_element(i)) continue;
    const ElementLayout& e = layout.elements[i];
    ElementJob job;
    job.sampling = options.sampling;
    const Strip strip = element_strip(e, job.sampling);
    job.element = ElementResult::of(e.group, e.element, e.orientation, e.lp_per_mm,
                                    e.bar_width_mm * view.px_per_mm_across(strip.center_mm, e.orientation));
    ElementResult& r = job.element;
    job.sampling.bin_px = options.bin_px_for(r.px_per_bar);
    job.placements.push_back({&view, &artwork, strip});
    jobs.push_back(std::move(job));
    index.push_back(i);
  }
  return jobs;
}

// The graded jobs in layout order, with the elements the plan did not fit
// taken from the measurement it carries.
std::vector<ElementResult> merge_carried(const std::vector<ElementResult>& fitted, const std::vector<size_t>& index,
                                         const FramePlan& plan, size_t n_elements) {
  if (!plan.carried || !plan.fit_element) return fitted;
  if (plan.carried->size() != n_elements)
    throw std::invalid_argument("FramePlan::carried must hold every element of the layout, in layout order");
  std::vector<ElementResult> all = *plan.carried;
  for (size_t k = 0; k < fitted.size(); ++k) all[index[k]] = fitted[k];
  return all;
}

// What a person must know about a light that varies over the target.
void note_gain_fields(Measurement& M) {
  for (const BarOrientation o : {BarOrientation::horizontal_bars, BarOrientation::vertical_bars}) {
    const GainField& f = M.reference.field(o);
    if (!f.plane) continue;
    M.warnings.push_back(fmt::format(
        "the shading gain across the {} varies over the target (a light whose direction changes from place to "
        "place): each element is normalised by a plane fitted to the patch and {} coarse elements{}",
        o == BarOrientation::horizontal_bars ? "horizontal bars" : "vertical bars", f.samples - 1,
        f.spread > kStronglyNonUniformSpread
            ? fmt::format("; strongly non-uniform (the step changes by up to {:.0f}% of the patch's), so "
                          "elements far from the patch carry the plane's error",
                          100 * f.spread)
            : ""));
  }
}


// The reference patch of a tracked frame whose light has not changed: the
// track's, with the frame decoded as the track's frame was. Returns the
// frame re-decoded when the track switched curves (empty otherwise).
cv::Mat carry_reference(const LoadedImage& image, const LayoutTrack& track, Measurement& M) {
  M.reference = track.reference;
  M.transfer = track.transfer;
  M.transfer_check = track.transfer_check;
  if (!M.transfer_check.message.empty()) M.warnings.push_back(M.transfer_check.message);
  if (track.transfer.curve.name() == image.transfer.curve.name()) return {};
  return redecode(image.luminance, image.transfer.curve, track.transfer.curve);
}

// Fiducials and pose into M: near the track first, when there is one.
// Returns the camera the target is seen through (nullopt: `camera`), or
// sets M.problem.
struct Located {
  bool ok = false;
  bool tracked = false;
  std::optional<CameraModel> fitted;
};

Located locate_target(const LoadedImage& image, const TargetLayout& layout, const CameraModel* camera,
                      const MeasureOptions& options, const FramePlan& plan, Measurement& M) {
  Located L;
  Stopwatch t;
  // (A copy only when pixels are masked: it costs ~1 ms per megapixel.)
  const cv::Mat& lum_in = image.luminance;
  const cv::Mat detection_image = image.non_finite_pixels == 0 ? lum_in : filled_for_detection(lum_in);
  PoseOptions po;
  po.boundary_points = options.pose_boundary_points;
  const bool distorting = camera && !camera->is_pinhole();
  std::optional<CameraModel> search_camera;
  const LayoutTrack* track = nullptr;
  if (plan.track) {
    M.fiducials = track_fiducials(detection_image, plan.track->fiducials);
    if (!M.fiducials.found)
      M.fiducials = find_near_track(detection_image, layout, *plan.track, plan.search_margin, distorting);
    if (M.fiducials.found) {
      track = plan.track;
      po.initial_rt = plan.track->rt_camera_from_target_mm;
    }
  }
  if (!M.fiducials.found) search_camera = find_target(detection_image, layout, camera, po, M);
  M.stage_seconds.push_back({"locate_fiducials", t.seconds()});
  if (!M.fiducials.found) {
    M.problem = M.fiducials.problem.empty() ? "no target found" : M.fiducials.problem;
    // Masked pixels hide what lies under them: say how many.
    if (image.non_finite_pixels > 0)
      M.problem += fmt::format("; {} pixel(s) are NaN/Inf and were masked, and a fiducial under them cannot be found",
                               image.non_finite_pixels);
    return L;
  }
  t.restart();
  L.fitted = fit_target_pose(image, layout, camera, search_camera, po, track, M);
  M.stage_seconds.push_back({"pose", t.seconds()});
  if (!M.pose.usable || (!camera && !L.fitted)) {
    M.problem = "the fiducials do not fit the layout (" + M.pose.problem +
                "): is this the layout of the captured target, and the right camera model?";
    return L;
  }
  if (M.pose.rms_px > 2.0) {
    // Without a camera model a pinhole is fitted, and a lens's distortion
    // shows as this misfit: the likeliest fix comes first.
    M.problem = fmt::format(
        "the fiducials fit the layout poorly (reprojection RMS {:.2f} px): {}",
        M.pose.rms_px,
        camera ? "wrong layout, wrong camera model, or a strongly deformed target"
               : "no --camera was given, and a pinhole does not fit this lens; pass the lens's mrcal model with "
                 "--camera (else: wrong layout, or a strongly deformed target)");
    return L;
  }
  if (track && M.pose.rms_px > std::max(3 * track->pose_rms_px, 0.3)) {
    M.problem = fmt::format(
        "the discs found near the frame before's fit its pose poorly (reprojection RMS {:.2f} px against "
        "{:.2f} px): measure the frame from scratch",
        M.pose.rms_px, track->pose_rms_px);
    return L;
  }
  L.ok = true;
  L.tracked = track != nullptr;
  return L;
}

}  // namespace

Measurement measure_capture(const LoadedImage& image, const TargetLayout& layout, const CameraModel* camera,
                            const MeasureOptions& options) {
  return measure_frame(image, layout, camera, options, {}).measurement;
}

FrameResult measure_frame(const LoadedImage& image, const TargetLayout& layout, const CameraModel* camera,
                          const MeasureOptions& options, const FramePlan& plan) {
  options.validate();
  FrameResult out;
  Measurement& M = out.measurement;
  M.image_width = image.width;
  M.image_height = image.height;
  if (camera) {
    camera->check_image_size(image.width, image.height);
    M.camera_source = camera->source();  // read, even if the target is not found
  }
  if (const double share = clipped_share(image); share > 0.5) {
    M.problem = fmt::format(
        "the capture is saturated: {:.0f}% of the pixels are at the clip level; reduce exposure or "
        "illumination and capture again",
        100.0 * share);
    return out;
  }
  const Located located = locate_target(image, layout, camera, options, plan, M);
  if (!located.ok) return out;
  out.tracked = located.tracked;
  const CameraModel& cam = camera ? *camera : *located.fitted;
  const TargetView view(cam, M.pose.rt_camera_from_target_mm);
  const IndexedArtwork artwork(layout.artwork, 0.0);
  const double clip_level = image.saturation_level;

  const TargetView::Nyquist nyq = view.nyquist({0.5 * layout.width_mm, 0.5 * layout.height_mm});
  M.nyquist_h_lp_per_mm = nyq.horizontal_bars_lp_per_mm;
  M.nyquist_v_lp_per_mm = nyq.vertical_bars_lp_per_mm;

  // Reference patch: the contrast scale per direction, the signature
  // (printed bars vs relief through a gel) when it is not given, and the
  // check that the pixels were decoded with the curve the patch fits.
  Stopwatch t;
  const bool carry = plan.track && plan.reuse_reference;
  bool encoding_mismatch = carry && plan.track->encoding_mismatch;
  cv::Mat redecoded;
  if (carry) {
    redecoded = carry_reference(image, *plan.track, M);
  } else {
    const PatchScene patch_scene{view, layout, artwork, clip_level, camera != nullptr};
    std::tie(redecoded, encoding_mismatch) = fit_reference(image, patch_scene, options, M);
  }
  out.reference_refit = !carry;
  const cv::Mat& lum = redecoded.empty() ? image.luminance : redecoded;
  const ReferenceResult& ref = M.reference;
  M.stage_seconds.push_back({"reference_patch", t.seconds()});
  if (!ref.usable) {
    M.problem = ref.problem;
    return out;
  }

  t.restart();
  std::vector<size_t> index;
  const std::vector<ElementJob> jobs = layout_jobs(layout, view, artwork, options, plan, index);
  const auto profiles = sample_jobs(lum, jobs, clip_level);
  M.stage_seconds.push_back({"profiles", t.seconds()});
  // A relief's step follows the light's direction over the target
  // (gain_field.h); printed bars' step is the ink's, the same everywhere.
  // A carried reference carries its field.
  if (ref.signature == Signature::shading && !carry) {
    t.restart();
    estimate_gain_fields(jobs, profiles, layout, M.reference);
    M.stage_seconds.push_back({"gain_field", t.seconds()});
  }
  if (ref.signature == Signature::shading) note_gain_fields(M);
  std::vector<ElementResult> fitted;
  // The code rounding under the curve the pixels were measured in (a
  // switched curve re-decoded them).
  CodeRounding rounding = image.rounding;
  rounding.curve = M.transfer.curve;
  const GradingContext context{ref, options, encoding_mismatch, false, nullptr, rounding};
  M.stage_seconds.push_back({"fits", grade_jobs(jobs, profiles, context, fitted)});
  M.elements = merge_carried(fitted, index, plan, layout.elements.size());

  // Decide.
  t.restart();
  decide_limits(M, options.criterion, options.detectability, false);
  M.stage_seconds.push_back({"decide", t.seconds()});
  M.usable = true;

  LayoutTrack& next = out.track.emplace();
  next.rt_camera_from_target_mm = M.pose.rt_camera_from_target_mm;
  next.fitted_camera = located.fitted;
  next.fiducials = M.fiducials;
  next.pose_rms_px = M.pose.rms_px;
  next.reference = M.reference;
  next.transfer = M.transfer;
  next.transfer_check = M.transfer_check;
  next.encoding_mismatch = encoding_mismatch;
  return out;
}

}  // namespace tactres
