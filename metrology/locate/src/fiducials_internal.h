#pragma once
// Private to locate: what the stages of find_fiducials (fiducials.h) hand
// each other. The search runs, per detection scale and mode:
//   fiducial_pattern.cpp     the layout's 5-disc pattern (Pattern)
//   fiducial_foreground.cpp  where the image departs from its ground
//                            (normalise: inked discs; relief_mask: rims)
//   fiducial_candidates.cpp  disc-like blobs in it (detect_mode -> Blob)
//   fiducial_centroid.cpp    printed discs and rings measured at full
//                            resolution (refine_centroid -> Refined)
//   fiducial_relief.cpp      shaded discs' rims fitted (refine_relief)
//   fiducial_identify.cpp    which blob is which disc (identify -> Verdict),
//                            each hypothesis checked by fiducial_verify.cpp
//                            (relief crescents: fiducial_light_field.cpp)
//   fiducials.cpp            the orchestration, scale by scale, mode by mode

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "homography.h"
#include "tactres/locate/fiducials.h"
#include "tactres/targets/geometry.h"
#include "tactres/targets/layout.h"

namespace tactres::locate_detail {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kInf = std::numeric_limits<double>::infinity();

// A symmetric 2x2 matrix: second moments (px^2) and ellipse metrics.
struct Sym2 {
  double xx = 0, xy = 0, yy = 0;
  double det() const { return xx * yy - xy * xy; }
  double trace() const { return xx + yy; }
  // Eigenvalues, largest first.
  std::pair<double, double> eig() const {
    const double h = 0.5 * (xx - yy);
    const double s = std::sqrt(h * h + xy * xy);
    return {0.5 * trace() + s, 0.5 * trace() - s};
  }
  Sym2 inverse() const {
    const double d = det();
    return {yy / d, -xy / d, xx / d};
  }
  // Inverse square root, for whitening.
  Sym2 inv_sqrt() const {
    const auto [l1, l2] = eig();
    const double theta = 0.5 * std::atan2(2 * xy, xx - yy);
    const double c = std::cos(theta), s = std::sin(theta);
    const double a = 1 / std::sqrt(l1), b = 1 / std::sqrt(l2);
    return {a * c * c + b * s * s, (a - b) * c * s, a * s * s + b * c * c};
  }
  Vec2 mul(Vec2 v) const { return {xx * v.x + xy * v.y, xy * v.x + yy * v.y}; }
  double quad(Vec2 v) const { return v.x * (xx * v.x + xy * v.y) + v.y * (xy * v.x + yy * v.y); }
};

// The q-quantile of v (reordered in place), 0 if empty: robust levels and
// noise from samples.
inline double percentile_of(std::vector<float>& v, double q) {
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

// ---------------------------------------------------------------------------
// The layout's fiducial pattern (fiducial_pattern.cpp).

struct Pattern {
  std::vector<Vec2> p;  // centres, mm, layout order
  std::vector<std::string> id;
  double r_mm = 0;
  int a = 0, m = 0, b = 0;    // the collinear triple; m strictly between, nearer a
  int c = 0, d = 0;           // the other two; c nearer a
  std::array<Vec2, 4> field;  // the field's corners, mm
  double ab_mm = 0;
  RectMm patch;  // the reference patch (area 0 if none)
  // The disc radius over the spread of the artwork's outlines, (det C)^(1/4)
  // with C their length-weighted second central moments (mm^2): what an
  // image's edges alone say about the discs' size (see detect_mode). 0 when
  // the layout lists no artwork.
  double disc_per_spread = 0;
};

// Throws std::invalid_argument unless the layout's fiducials are the 5-disc
// pattern of fiducials.h.
Pattern make_pattern(const TargetLayout& layout);

// ---------------------------------------------------------------------------
// Where the image departs from its ground (fiducial_foreground.cpp).

// Per-thread buffers for the detection-scale images. Fresh image-sized
// buffers each call cost more in page faults (zeroed pages, memory-cgroup
// accounting) than the arithmetic on them, several ms per call: kept
// between calls, ~9 MB per thread for a 1280x720 capture's coarse pass
// (full-resolution buffers are released after each call).
struct Workspace {
  cv::Mat img;                                          // the detection-scale copy
  cv::Mat log_img, log_mean, n8, otsu_scratch;          // normalise()
  cv::Mat fine, bg, small, thr_small, thr, mag, patched;  // relief_mask()
  cv::Mat edges, relief, count, closed, padded;         // 8-bit masks
  std::array<cv::Mat*, 16> all() {
    return {&img, &log_img, &log_mean, &n8, &otsu_scratch, &fine, &bg, &small,
            &thr_small, &thr, &mag, &patched, &edges, &relief, &count, &padded};
  }
  // Releases the buffers of more than max_pixels elements.
  void trim(size_t max_pixels) {
    for (cv::Mat* m : all())
      if (m->total() > max_pixels) m->release();
    if (closed.total() > max_pixels) closed.release();
  }
};

// This thread's buffers.
Workspace& workspace();

// A background-normalised copy of the image at one detection scale.
struct Normalised {
  bool blank = true;
  cv::Mat n;         // log(I) - its local mean
  cv::Mat n8;        // n mapped to 8 bits, 0 at 127.5
  double otsu = 0;   // Otsu threshold of n8
  double sn = 0;     // robust maximum of |n|
  double noise = 0;  // robust standard deviation of n
};

Normalised normalise(const cv::Mat& img);

// Where a relief seen through a gel shows its edges (see relief_mask()).
struct ReliefMask {
  bool blank = true;
  cv::Mat mask;  // CV_8U, 255 where the deviation is significant
};

ReliefMask relief_mask(const cv::Mat& img);

// ---------------------------------------------------------------------------
// Candidate blobs (fiducial_candidates.cpp).

struct Blob {
  Vec2 center;      // full-resolution px
  Sym2 cov;         // second moments of the filled shape, full-resolution px^2
  double area = 0;  // full-resolution px^2
  double residual = 0;
  double axis_ratio = 1;
  int contour = -1;   // index into Detection::contours[polarity]
  int contour2 = -1;  // a shaded disc's other crescent, when apart
  double pixel = 1;  // detection pixel size, full-resolution px
};

// How a disc differs from its ground: darker, lighter, or both (a relief
// under a directional light shows a light and a dark crescent).
inline constexpr int kDark = 0, kLight = 1, kShaded = 2;

struct Detection {
  int scale = 1;
  // Per mode (kDark, kLight, kShaded): every outer contour (for the
  // foreign-ink guard of the centroid window) and the disc-like blobs among
  // them.
  std::array<std::vector<std::vector<cv::Point>>, 3> contours;
  std::array<std::vector<cv::Rect>, 3> rects;
  std::array<std::vector<Blob>, 3> blobs;
};

// Thresholds one mode's image (dark, light or shaded discs) and keeps the
// elliptical blobs, in `det`. `relief` is used by the shaded mode only, as
// is `disc_per_spread` (Pattern).
void detect_mode(const Normalised& nz, const ReliefMask& relief, int pol,
                 const FiducialSearchOptions& o, double disc_per_spread, Detection& det);

// ---------------------------------------------------------------------------
// Sub-pixel area centroid at full resolution (fiducial_centroid.cpp,
// fiducial_relief.cpp).

// A disc measured at full resolution. Printed discs and rings
// (refine_centroid): coverage-weighted moments. Shaded discs
// (refine_relief): the fitted rim ellipse, as if filled.
struct Refined {
  bool ok = false;
  Vec2 centroid;
  double area = 0;  // sum(w), px^2; shaded: the rim ellipse's area
  Sym2 cov;         // second central moments, px^2; shaded: the filled rim ellipse's
  double contrast = 0;
  double ground = 0;  // ground level at the centre
  // Shaded discs only: sum((I - g)(x - c)) / sum(|I - g|) over the rim, px:
  // the axis from the dark to the light crescent (near zero for a ring).
  Vec2 dipole;
  // Printed discs and rings only: the strongest deviation of the OPPOSITE
  // sign near the blob (lighter than the ground around a dark blob), over
  // the blob's own. ~0 for an inked disc or a ring; ~0.3-1 when the blob is
  // one crescent of a relief under a directional light, whose other
  // crescent lies a disc's diameter away (see opposite_deviation()).
  // Measured on demand (RefinedCache::opposite), from the ground plane
  // g[0] + g[1] (x - gc.x) + g[2] (y - gc.y) and whether it scales delta.
  double opposite = -1;
  std::array<double, 3> g{};
  Vec2 gc;
  bool multiplicative = false;
};

// Distance (px) from the blob's moment ellipse to the nearest other mark
// of mode `pol` within `reach_px` of it (infinity if none): the window that
// measures a disc must not take in another mark's tails.
double clearance_px(const Blob& blob, const Detection& det, int pol, double reach_px);

// Printed discs (dark or light) and rings: the coverage-weighted centroid.
Refined refine_centroid(const cv::Mat& lum, const Blob& blob, const Detection& det, int pol);
// Shaded discs: the centre of the rim's ellipse.
Refined refine_relief(const cv::Mat& lum, const Blob& blob, const Detection& det);
// Refined::opposite of a refined printed disc or ring.
double opposite_deviation(const cv::Mat& lum, const Blob& blob, const Refined& R, bool dark);

// Refinement on first use: only blobs that take part in a plausible
// hypothesis are ever refined.
class RefinedCache {
 public:
  RefinedCache(const cv::Mat& lum, const Detection& det, int pol)
      : lum_(lum),
        det_(det),
        pol_(pol),
        done_(det.blobs[pol].size(), 0),
        r_(det.blobs[pol].size()) {}
  // The refined blob b, or nullptr if it cannot be measured.
  const Refined* get(int b);
  // Refined::opposite of a refined printed disc or ring (0 when shaded).
  double opposite(int b);
  const cv::Mat& image() const { return lum_; }

 private:
  const cv::Mat& lum_;
  const Detection& det_;
  int pol_;
  std::vector<char> done_;
  std::vector<Refined> r_;
};

// ---------------------------------------------------------------------------
// Identification: which blobs are which layout disc (fiducial_identify.cpp,
// fiducial_verify.cpp).

struct Verdict {
  bool ok = false;
  double score = kInf;
  Homography H{};
  double rms_px = 0;
  int n = 0;
  std::array<int, 5> cand{-1, -1, -1, -1, -1};  // blob index per layout disc
  bool seen = false;  // the discs fit, but the reference patch was not there
  // Printed/ring modes: most discs have a strong opposite-sign neighbour
  // (Refined::opposite), as the crescents of a relief under a directional
  // light do. Such an answer is kept only if no other mode explains the
  // discs (find_fiducials), and never on four discs.
  bool bipolar = false;
};

struct Identification {
  Verdict verdict;        // ok when identified (n = 4 or 5)
  int partial_count = 0;  // discs seen in the best unidentified partial pattern
  bool ambiguous = false;
};

Identification identify(const std::vector<Blob>& blobs, const Pattern& pat,
                        const FiducialSearchOptions& o, RefinedCache& refined, bool shaded);

}  // namespace tactres::locate_detail
