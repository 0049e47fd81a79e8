// Disc candidates at one detection scale and mode: the mode's foreground
// thresholded into a mask (for shaded discs, rims closed into rings), its
// outlines, and those elliptical enough to be a disc's image (Blob).

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "fiducials_internal.h"

namespace tactres::locate_detail {

namespace {

// The shaded mode's mask: the relief mask without isolated specks, closed
// so that each disc's two crescents make one ring. Written into the
// workspace (ws.closed); W x H is the detection-scale image's size.
cv::Mat closed_rims(const ReliefMask& relief, double disc_per_spread, int W, int H) {
  // Isolated specks (noise, what is left of side lobes) go first, or the
  // closing below would tie them to a disc as spurs: a pixel stays if at
  // least two of its 8 neighbours are set (thin rims keep theirs).
  Workspace& ws = workspace();
  cv::boxFilter(relief.mask, ws.count, CV_16U, cv::Size(3, 3), cv::Point(-1, -1), false,
                cv::BORDER_CONSTANT);
  cv::Mat mask = ws.closed;
  cv::compare(ws.count, 3 * 255, mask, cv::CMP_GE);
  ws.closed = mask;
  cv::bitwise_and(mask, relief.mask, mask);
  // A disc's two crescents fade out where its edge runs along the light;
  // a closing of ~0.6 of the disc's radius joins them into one ring, whose
  // convex hull is the disc (below). It must stay well below the gap
  // between a disc and the nearest other mark (> 3.5 radii in the default
  // layout), or it ties the disc to the bars. The discs' size is not known
  // yet, but the target's is: the second moments of where the image shows
  // edges, against those of the layout's outlines, give the scale
  // (px per mm, geometric mean over the tilt). Clutter beyond the target
  // can only enlarge it: bounded by ~1 % of the image, a third of a
  // disc's radius when the target fills the image.
  const int rk_max = std::max(2, static_cast<int>(std::lround(0.012 * std::min(W, H))));
  int rk = rk_max;
  if (disc_per_spread > 0) {
    const cv::Moments m = cv::moments(mask, true);
    const Sym2 C{m.mu20 / std::max(m.m00, 1.0), m.mu11 / std::max(m.m00, 1.0),
                 m.mu02 / std::max(m.m00, 1.0)};
    if (m.m00 >= 64 && C.det() > 0) {
      const double r_disc = disc_per_spread * std::sqrt(std::sqrt(C.det()));
      rk = std::clamp(static_cast<int>(std::lround(0.6 * r_disc)), 2, rk_max);
    }
  }
  // An octagon (3x3 crosses, then 3x3 squares): within 6 % of a disc, at
  // a cost that grows with its radius, not with its area. On a copy padded
  // with empty ground: beyond the frame there is nothing to close over
  // (with the image's border counted as set, as cv::erode does, a disc
  // within rk of the frame would be tied to it, and dropped as clipped).
  const int n_cross = rk / 2, n_square = rk - n_cross;
  static const cv::Mat kCross = cv::getStructuringElement(cv::MORPH_CROSS, cv::Size(3, 3));
  cv::Mat& pad = ws.padded;
  cv::copyMakeBorder(mask, pad, rk, rk, rk, rk, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::dilate(pad, pad, kCross, cv::Point(-1, -1), n_cross);
  cv::dilate(pad, pad, cv::Mat(), cv::Point(-1, -1), n_square);
  cv::erode(pad, pad, kCross, cv::Point(-1, -1), n_cross);
  cv::erode(pad, pad, cv::Mat(), cv::Point(-1, -1), n_square);
  pad(cv::Rect(rk, rk, W, H)).copyTo(mask);
  return mask;
}

// One mode's mask at the detection scale: 255 where the mode's discs may be.
cv::Mat mode_mask(const Normalised& nz, const ReliefMask& relief, int pol, double disc_per_spread,
                  int W, int H) {
  if (pol == kShaded) return closed_rims(relief, disc_per_spread, W, H);
  cv::Mat mask;
  if (pol == kDark) cv::threshold(nz.n8, mask, nz.otsu, 255, cv::THRESH_BINARY_INV);
  if (pol == kLight) cv::threshold(nz.n8, mask, nz.otsu, 255, cv::THRESH_BINARY);
  // Where Otsu cuts through noise (a capture with no inked marks, e.g. a
  // relief), the mask is salt and pepper, and thousands of ragged contours
  // would cost far more than the search: a 3x3 median clears them and
  // leaves any disc of more than ~2 px radius.
  cv::medianBlur(mask, mask, 3);
  return mask;
}

// What makes an outline a disc candidate, at the detection scale.
struct BlobTest {
  int pol = kDark;
  int scale = 1;        // detection pixel, full-resolution px
  double cos_tilt = 1;  // of the largest tilt allowed
  double r_min = 2;     // equivalent radius bounds, detection-scale px
  double r_max = 0;
};

// The points of a polygon's edges, one per detection pixel along each.
std::vector<cv::Point> densified(const std::vector<cv::Point>& hull) {
  std::vector<cv::Point> dense;
  for (size_t k = 0; k < hull.size(); ++k) {
    const cv::Point a = hull[k], e = hull[(k + 1) % hull.size()];
    const int steps = std::max(std::abs(e.x - a.x), std::abs(e.y - a.y));
    for (int t = 0; t < steps; ++t)
      dense.push_back({a.x + (e.x - a.x) * t / steps, a.y + (e.y - a.y) * t / steps});
  }
  return dense;
}

// Tests one outline (a contour, or for shaded discs the points of two) and
// keeps it as a blob in det.blobs[pol] if it is elliptical enough.
bool try_blob(const std::vector<cv::Point>& c, int idx, int idx2, const BlobTest& t,
              Detection& det) {
  const int pol = t.pol, scale = t.scale;
  std::vector<cv::Point> hull;
  cv::convexHull(c, hull);
  // A shaded disc's crescents may stay apart at one tip (a "C"): its
  // convex hull is the disc's outline. Elsewhere the outline itself is
  // tested, and must be nearly convex.
  std::vector<cv::Point> dense_hull;
  if (pol == kShaded) {
    dense_hull = densified(hull);
    if (dense_hull.size() < 8) return false;
  }
  const auto& outline = pol == kShaded ? dense_hull : c;
  const cv::Moments mo = cv::moments(pol == kShaded ? hull : c);
  const double A = std::abs(mo.m00);
  // Contour vertices are boundary pixel centres, half a pixel inside the edge.
  const double r_eq = std::sqrt(A / kPi) + 0.5;
  if (r_eq < 0.8 * t.r_min || r_eq > t.r_max) return false;
  if (pol != kShaded && A < 0.85 * cv::contourArea(hull)) return false;
  const Vec2 cen{mo.m10 / mo.m00, mo.m01 / mo.m00};
  Sym2 C{mo.mu20 / mo.m00, mo.mu11 / mo.m00, mo.mu02 / mo.m00};
  const auto [l1, l2] = C.eig();
  if (!(l2 > 0)) return false;
  const double axis_ratio = std::sqrt(l2 / l1);
  if (axis_ratio < 0.75 * t.cos_tilt) return false;
  // Normalised radius of each outline point in the moment ellipse's
  // metric: constant for an ellipse (under any affine map), 0.87..1.22
  // for any parallelogram (bars, patch, label segments).
  const Sym2 Ci = C.inverse();
  double s1 = 0, s2 = 0;
  for (const cv::Point& q : outline) {
    const double rho = std::sqrt(Ci.quad({q.x - cen.x, q.y - cen.y}));
    s1 += rho;
    s2 += rho * rho;
  }
  const double mean = s1 / outline.size();
  const double rel = std::sqrt(std::max(0.0, s2 / outline.size() - mean * mean)) / mean;
  // A shaded disc's outline is rougher (crescent tips, what the closing
  // joined); refine_relief() and the identification check the disc itself.
  if (rel > (pol == kShaded ? 0.1 : 0.06) + 0.25 / r_eq) return false;
  const double inflate = std::pow(r_eq / (r_eq - 0.5), 2);
  Blob b;
  b.center = {scale * cen.x + 0.5 * (scale - 1), scale * cen.y + 0.5 * (scale - 1)};
  const double s2f = inflate * scale * scale;
  b.cov = {C.xx * s2f, C.xy * s2f, C.yy * s2f};
  b.area = A * s2f;
  b.residual = rel;
  b.axis_ratio = axis_ratio;
  b.contour = idx;
  b.contour2 = idx2;
  b.pixel = scale;
  det.blobs[pol].push_back(b);
  return true;
}

// Small shaded outlines: maybe one crescent of a disc whose other crescent
// the closing did not reach (a dim disc's crescents fade over a wide
// angle). Their centres and sizes, for pairing.
struct Fragment {
  int idx;
  Vec2 center;
  double radius;
};

// Pairs of fragments close enough to be the two crescents of one disc,
// tested as one outline.
void pair_fragments(const std::vector<Fragment>& fragments, const BlobTest& t, Detection& det) {
  if (fragments.size() > 200) return;
  std::vector<cv::Point> both;
  for (size_t i = 0; i < fragments.size(); ++i)
    for (size_t j = i + 1; j < fragments.size(); ++j) {
      const Fragment &f = fragments[i], &g = fragments[j];
      if (norm(f.center - g.center) > 1.2 * (f.radius + g.radius) + 2) continue;
      const auto &cf = det.contours[t.pol][f.idx], &cg = det.contours[t.pol][g.idx];
      both.assign(cf.begin(), cf.end());
      both.insert(both.end(), cg.begin(), cg.end());
      try_blob(both, f.idx, g.idx, t, det);
    }
}

}  // namespace

void detect_mode(const Normalised& nz, const ReliefMask& relief, int pol,
                 const FiducialSearchOptions& o, double disc_per_spread, Detection& det) {
  if (pol == kShaded ? relief.blank : nz.blank) return;
  const int scale = det.scale;
  const int W = pol == kShaded ? relief.mask.cols : nz.n.cols;
  const int H = pol == kShaded ? relief.mask.rows : nz.n.rows;
  const cv::Mat mask = mode_mask(nz, relief, pol, disc_per_spread, W, H);

  BlobTest t;
  t.pol = pol;
  t.scale = scale;
  t.cos_tilt = std::cos(o.max_tilt_deg * kPi / 180);
  t.r_min = std::max(o.min_radius_px / scale, 2.0);  // detection-scale px
  t.r_max = 0.15 * std::min(W, H);
  std::vector<std::vector<cv::Point>> all;
  std::vector<cv::Vec4i> hierarchy;
  // Two levels (outlines and holes): every blob's outline is a top-level
  // contour, wherever it lies (e.g. on a card inside a darker surround), and
  // a ring's outline encloses its hole.
  cv::findContours(mask, all, hierarchy, cv::RETR_CCOMP, cv::CHAIN_APPROX_NONE);
  std::vector<Fragment> fragments;
  for (size_t i = 0; i < all.size(); ++i) {
    if (hierarchy[i][3] >= 0) continue;  // a hole, not a blob's outline
    auto& contour = all[i];
    const cv::Rect rect = cv::boundingRect(contour);
    const int idx = static_cast<int>(det.contours[pol].size());
    det.rects[pol].push_back(rect);
    det.contours[pol].push_back(std::move(contour));
    const auto& c = det.contours[pol].back();
    if (c.size() < 8) continue;
    if (rect.x <= 0 || rect.y <= 0 || rect.x + rect.width >= W || rect.y + rect.height >= H)
      continue;  // clipped by the frame: its centroid would be wrong
    if (std::max(rect.width, rect.height) > 2 * t.r_max) continue;
    try_blob(c, idx, -1, t, det);
    // (One crescent alone can pass as a thick ellipse, off the disc's
    // centre: every small one is a fragment.)
    if (pol == kShaded && std::max(rect.width, rect.height) < t.r_max)
      fragments.push_back({idx, {rect.x + 0.5 * rect.width, rect.y + 0.5 * rect.height},
                           0.5 * std::max(rect.width, rect.height)});
  }
  pair_fragments(fragments, t, det);
  auto& bl = det.blobs[pol];
  std::sort(bl.begin(), bl.end(),
            [](const Blob& x, const Blob& y) { return x.residual < y.residual; });
  if (bl.size() > static_cast<size_t>(o.max_candidates)) bl.resize(o.max_candidates);
}

}  // namespace tactres::locate_detail
