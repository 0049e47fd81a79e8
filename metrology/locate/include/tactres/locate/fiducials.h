#pragma once
// Finds and identifies the target's five fiducial discs in a capture
// (docs/ARCHITECTURE.md, "measure").
//
// The layout has five equal discs: TL, TR, BL, BR near the corners and T3 on
// the top edge a third of the way from TL to TR. Identification is purely
// geometric, so it holds at any in-plane rotation and in mirrored
// (through-gel) views: the only collinear triple with a disc strictly between
// two others is (TL, T3, TR), and a plane homography fitted to all five
// correspondences must map the layout's field without folding it. The image's
// handedness is never used. Each hypothesis is then checked against what
// the map predicts: every disc's image area and shape, and, for printed
// (inked) targets, ink where the reference patch should be.
//
// Four discs are enough (and reported, with a warning) when they identify
// themselves: always for a printed target (with T3 hidden, the patch decides
// between the rectangle's symmetric labellings); never for rings or shaded
// discs, whose images say too little.
//
// Centroids are sub-pixel AREA centroids of each disc's image: the
// coverage-weighted centroid sum(w x) / sum(w) with
// w = clamp((I - ground) / (ink - ground), 0, 1), ground a plane fitted to an
// annulus around the disc (so smooth illumination gradients cancel) and ink
// the disc's extreme level. For an exact area-coverage render this is the area
// centroid of the projected disc, and it does not move under symmetric blur.
// That is what fit_pose() (pose.h) predicts for each disc.
//
// Rings (a relief seen through a gel, shaded by the slope's magnitude) get
// the same weights, so their centroid is the ring's.
//
// Shaded discs: a relief pressed into a gel and lit from one side shows each
// disc only as a thin light and a thin dark crescent (~2 px wide), on an
// illumination that varies far more than they do (diffuser spot,
// vignetting, hot spots). They are found on the deviation from a local
// background, thresholded against the noise expected at that background's
// level (measured from the image: read and shot noise), closed into rings
// (or paired, when a dim disc's crescents stay apart) and filled by their
// convex hull. The centre is then fitted to WHERE the rim is, not to how
// bright it is: along rays from the current centre, the centroid of
// |I - ground| across the rim is a point of the disc's edge (the gel and the
// optics blur the edge symmetrically, whatever the shading makes of its
// height), and an ellipse fitted to those points is the disc's image, whose
// centre is the projected disc's area centroid. It does not depend on the
// crescents' brightness: |I - ground| weights move toward the stronger
// crescent (a 2 % imbalance between them moves a 12 px disc's centroid by
// ~0.15 px; full Lambert shading darkens one side far more than it lights
// the other: 1.5-4 px), and the mean of the light and dark crescents'
// centroids depends on how each fades along the rim (0.04 px under
// linearised, 0.5-1 px under full Lambert shading). Measured on noise-free
// renders of the example design scenes and variants: the rim fit is within
// 0.03 px of project_disc_centroid (pose.h); under their sensor noise
// (~35-40 dB) ~0.01-0.04 px rms. The fitted ellipses must match the discs
// the pattern's map predicts, and under one light every disc's light
// crescent lies on the same side.
//
// Crescents taken for discs: small relief discs (radius ~5 px) blurred by
// ~3 px show each crescent as a compact blob, and the five dark (or light)
// crescents fit the pattern as printed discs, all displaced by ~a radius.
// Such discs betray themselves by a strong deviation of the opposite sign
// beside each (the other crescent; nothing on a print is lighter than its
// ground around a dark disc). When most discs of a printed-mode answer have
// one, it does not end the search: every other mode, at both scales, may
// replace it, and if none does (the shaded mode cannot fit rims that small)
// the capture is refused with a problem saying so, never reported with
// centroids a radius off; four such discs are never accepted.
//
// Pixel convention (mrcal's and OpenCV's): the top-left pixel's centre is
// (0, 0).
//
// Cost (one core of a shared, loaded machine, 1280x720): ~2 ms for a
// printed capture found on the 2x-downsampled pass, ~4.5-5.5 ms for a relief
// one (every mode is tried on that pass first); ~45 ms when nothing is found
// (every mode at both scales). 2448x2048 (5.4x the pixels): ~15 ms printed,
// ~40 ms relief, ~230 ms when nothing is found. Per-thread buffers (~9 MB
// for 1280x720) are kept between calls: fresh ones cost more in page faults
// than the arithmetic.

#include <array>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "tactres/targets/geometry.h"
#include "tactres/targets/layout.h"

namespace tactres {

struct FiducialSearchOptions {
  // Smallest disc radius (px) to look for, in (1, 1000]. Discs are searched
  // on a 2x-downsampled copy first (fast); full resolution is searched only
  // if that finds no complete pattern.
  double min_radius_px = 2.5;
  // Largest angle between the target's normal and the line of sight, in
  // [0, 80] degrees. It bounds the apparent elongation of the discs.
  double max_tilt_deg = 60.0;
  // Largest ratio between the apparent areas of two discs of one target, in
  // [1.5, 100]: tilt and perspective make near discs look larger.
  double max_area_ratio = 4.0;
  // The disc centroids must fit a plane homography to within this RMS
  // fraction of the TL-TR distance, and TL, T3, TR be collinear to within
  // it; the discs' shapes may deviate from the homography's prediction more
  // as it grows. The default leaves room for moderate lens distortion (~5 %
  // at the target's corners); raise it for fisheye lenses, at a higher risk
  // of taking a chance arrangement of round blobs for the target. (0, 0.2].
  double max_fit_error_frac = 0.02;
  // Disc-like blobs kept per polarity (best ellipse fits first), in [5, 1000].
  int max_candidates = 40;
  // Search the 2x-downsampled copy only (images of >= 400 px; smaller ones
  // are searched at full resolution anyway). For a caller with a cheaper
  // second try (a lens-rectified copy) before the costly full-resolution
  // pass.
  bool coarse_only = false;

  // Throws std::invalid_argument naming the bad option and its valid range.
  void validate() const;
};

struct FiducialDetection {
  std::string id;           // the layout's fiducial id: "TL", "T3", "TR", "BL", "BR"
  Vec2 centroid_px;         // area centroid of the disc's image (see above)
  double area_px = 0.0;     // coverage area sum(w), px^2: the projected disc's area
  double axis_ratio = 1.0;  // minor / major axis of the image ellipse (~cos tilt)
  // Relative RMS deviation of the blob's outline from its moment ellipse
  // (0 for a perfect ellipse, ~0.11 for a square).
  double ellipse_residual = 0.0;
  // ink - ground level at the disc centre, in input units: negative for a
  // dark disc on a light ground (|.|, positive, for shaded discs).
  double contrast = 0.0;
};

struct FiducialSearchResult {
  // True when at least 4 discs were found AND identified unambiguously
  // (fit_pose needs >= 4). With exactly 4, `warning` names the missing one.
  bool found = false;
  // Identified discs in layout.fiducials order (all 5, or 4 when found with
  // one missing; empty when !found).
  std::vector<FiducialDetection> discs;
  // Why !found, as a message a user can act on. Empty when found.
  std::string problem;
  // Set when found with only 4 discs: still usable, but the pose is weaker.
  std::string warning;
  // Polarity of the found discs: true for dark discs on a lighter ground.
  // Relief targets seen through a gel may show either.
  bool dark_on_light = true;
  // The discs showed as thin outlines, a light and a dark crescent (a relief
  // under a directional light) or rings: their centres are fitted to the
  // rims (see above), area_px is the rim ellipse's area, contrast the rim's
  // peak |I - ground|, and dark_on_light is false.
  bool shaded = false;
  // Row-major 3x3 homography from target mm (z = 0) to pixels, fitted to the
  // identified disc centroids (an affine map when the 4 found discs include
  // a collinear triple). A rough map for initial guesses only: it ignores
  // lens distortion and the centroid-vs-centre offset. Valid when found.
  std::array<double, 9> image_from_target{};
  // RMS of the centroids' residuals to that map, px (0 for an exact 4-point fit).
  double fit_rms_px = 0.0;
  // Disc-like blobs examined in the polarity that was kept (diagnostics).
  int candidates = 0;
};

// Finds the layout's fiducial discs in `luminance` (CV_32FC1, finite values,
// any scale; linear luminance is best). Tries the layout's polarity first,
// then the other one (relief targets through a gel show either, often as
// rings), then shaded discs (light and dark crescents), on the coarse pass
// and then, if none found all five, at full resolution.
// Throws std::invalid_argument for an empty or non-CV_32FC1 image, non-finite
// pixels, invalid options, or a layout whose fiducials are not the 5-disc
// pattern described above. "Not found" is a result, never an exception.
FiducialSearchResult find_fiducials(const cv::Mat& luminance, const TargetLayout& layout,
                                    const FiducialSearchOptions& options = {});

// A live sequence's search (`tactres watch`): each disc of `previous`, the
// result of the frame before, measured again where it was, with the same
// full-resolution centroid as find_fiducials and no blob search (a fraction
// of a millisecond instead of several). A disc may have moved by up to
// about half its radius. Not found when any disc cannot be measured there,
// or changed its size or contrast by more than a third (the target moved
// too far or left, or the light changed): the caller then searches.
FiducialSearchResult track_fiducials(const cv::Mat& luminance, const FiducialSearchResult& previous);

}  // namespace tactres
