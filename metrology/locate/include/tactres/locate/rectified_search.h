#pragma once
// Fiducial search on a lens-rectified copy of the capture.
//
// The fiducial search checks the disc pattern against a plane homography,
// which strong lens distortion bends (a wide-angle lens close to the
// target). When a camera model is known, the capture is resampled once
// into a distortion-free pinhole view that shares the model's rays; there
// the pattern is a homography again. The pose fitted through that pinhole
// is the pose of the real camera, since both see along the same rays.
//
// Only the search and the pose use the copy. Profiles are always sampled
// from the original pixels through the real lens model (docs/ARCHITECTURE.md).

#include <optional>

#include <opencv2/core.hpp>

#include "tactres/camera/camera_model.h"
#include "tactres/locate/fiducials.h"
#include "tactres/targets/layout.h"

namespace tactres {

struct RectifiedSearch {
  // Centroids in the rectified image, whose camera is `pinhole`.
  FiducialSearchResult fiducials;
  CameraModel pinhole;
};

// The distortion-free pinhole that sees the model's whole imager: the same
// principal point and imager size, the focal length shrunk (down to half)
// so that the rays of the imager's border stay inside. nullopt for a lens
// that cannot be rectified (rays at or beyond 90 degrees off axis).
std::optional<CameraModel> rectifying_pinhole(const CameraModel& camera);

// Resamples `image` (CV_32FC1, finite) into `pinhole`'s view through
// `camera`; pixels that see outside the capture repeat its border.
cv::Mat rectify(const cv::Mat& image, const CameraModel& camera, const CameraModel& pinhole);

// find_fiducials on the rectified copy. nullopt when the lens cannot be
// rectified; otherwise the search result, found or not.
std::optional<RectifiedSearch> find_fiducials_rectified(const cv::Mat& luminance, const TargetLayout& layout,
                                                        const CameraModel& camera,
                                                        const FiducialSearchOptions& options = {});

// Maps a rectified pixel back to the capture through the real lens.
std::optional<Vec2> unrectify_point(Vec2 rectified_px, const CameraModel& camera, const CameraModel& pinhole);

}  // namespace tactres
