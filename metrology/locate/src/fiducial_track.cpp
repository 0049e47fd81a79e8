// track_fiducials (fiducials.h): the discs of the frame before measured
// again where they were, with find_fiducials' own full-resolution centroid
// (fiducial_centroid.cpp, fiducial_relief.cpp), and no blob search.
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "fiducials_internal.h"

namespace tactres {

using namespace locate_detail;

namespace {

// A disc of the frame before as the blob the centroid starts from: a circle
// of its area around its centroid (a tilted disc's ellipse fits inside the
// window the centroid grows around it), and its outline as the mark the
// other discs' windows keep clear of.
Blob blob_of(const FiducialDetection& d, int contour, Detection& det, int pol) {
  const double r_px = std::sqrt(std::max(d.area_px, 1.0) / kPi);
  Blob b;
  b.center = d.centroid_px;
  b.cov = {0.25 * r_px * r_px, 0, 0.25 * r_px * r_px};
  b.area = d.area_px;
  b.axis_ratio = d.axis_ratio;
  b.residual = d.ellipse_residual;
  b.contour = contour;
  std::vector<cv::Point> outline;
  for (int k = 0; k < 32; ++k) {
    const double a = 2 * kPi * k / 32;
    outline.emplace_back(int(std::lround(d.centroid_px.x + r_px * std::cos(a))),
                         int(std::lround(d.centroid_px.y + r_px * std::sin(a))));
  }
  det.rects[pol].push_back(cv::boundingRect(outline));
  det.contours[pol].push_back(std::move(outline));
  return b;
}

}  // namespace

FiducialSearchResult track_fiducials(const cv::Mat& luminance, const FiducialSearchResult& previous) {
  FiducialSearchResult r;
  r.problem = "the fiducials are not where the frame before had them";
  if (!previous.found || previous.discs.size() < 4 || luminance.empty() || luminance.type() != CV_32FC1) return r;
  const int pol = previous.shaded ? kShaded : previous.dark_on_light ? kDark : kLight;
  Detection det;
  std::vector<Blob> blobs;
  for (const FiducialDetection& d : previous.discs) blobs.push_back(blob_of(d, int(blobs.size()), det, pol));
  for (size_t k = 0; k < blobs.size(); ++k) {
    const FiducialDetection& before = previous.discs[k];
    const Refined f = pol == kShaded ? refine_relief(luminance, blobs[k], det)
                                     : refine_centroid(luminance, blobs[k], det, pol);
    // A disc that changed its size or contrast by more than a third is not
    // the same disc seen again: the target moved too far, or the light changed.
    const double area_ratio = f.area / std::max(before.area_px, 1e-9);
    const double contrast_ratio = before.contrast != 0 ? f.contrast / before.contrast : 1;
    if (!f.ok || !(area_ratio > 0.67 && area_ratio < 1.5) || !(contrast_ratio > 0.67 && contrast_ratio < 1.5))
      return r;
    r.discs.push_back({before.id, f.centroid, f.area, before.axis_ratio, before.ellipse_residual, f.contrast});
  }
  r.found = true;
  r.problem.clear();
  r.dark_on_light = previous.dark_on_light;
  r.shaded = previous.shaded;
  r.candidates = int(r.discs.size());
  r.warning = previous.warning;
  // The homography stays the frame before's: only the pose fit, which
  // starts from the frame before's pose, uses the new centroids.
  r.image_from_target = previous.image_from_target;
  r.fit_rms_px = previous.fit_rms_px;
  return r;
}

}  // namespace tactres
