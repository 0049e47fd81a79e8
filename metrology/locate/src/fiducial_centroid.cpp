// Printed discs and rings measured at full resolution: the coverage-weighted
// area centroid of fiducials.h, on a ground plane fitted around the disc,
// and the opposite-sign check that tells a relief's crescent from an inked
// disc. Shaded discs are fitted by fiducial_relief.cpp.

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "fiducials_internal.h"

namespace tactres::locate_detail {

double clearance_px(const Blob& blob, const Detection& det, int pol, double reach_px) {
  const auto [l1, l2] = blob.cov.eig();
  const double semi_minor = 2 * std::sqrt(l2);
  const Sym2 Ci = blob.cov.inverse();
  const double s = det.scale, off = 0.5 * (s - 1);
  const double reach = 2 * std::sqrt(l1) * (1 + reach_px / semi_minor) + 2 * s;
  const cv::Rect2d box(blob.center.x - reach, blob.center.y - reach, 2 * reach, 2 * reach);
  double gap = kInf;
  const auto& contours = det.contours[pol];
  for (size_t k = 0; k < contours.size(); ++k) {
    // Specks of a pixel or two do not pull the centroid measurably.
    if (static_cast<int>(k) == blob.contour || static_cast<int>(k) == blob.contour2 ||
        contours[k].size() < 3)
      continue;
    const cv::Rect& r = det.rects[pol][k];
    const cv::Rect2d rf(s * r.x + off - s, s * r.y + off - s, s * r.width + 2 * s,
                        s * r.height + 2 * s);
    if ((rf & box).area() <= 0) continue;
    for (const cv::Point& p : contours[k]) {
      const Vec2 d{s * p.x + off - blob.center.x, s * p.y + off - blob.center.y};
      const double e = (std::sqrt(0.25 * Ci.quad(d)) - 1) * semi_minor - 0.5 * s;
      gap = std::min(gap, e);
    }
  }
  return gap;
}

// A relief under a directional light shows each disc as a dark and a light
// crescent, a disc's diameter apart; once blurred to ~half the disc's radius
// each crescent is a compact blob that passes for a small printed disc (or a
// ring), and all five are displaced alike, so they fit the pattern. What
// betrays them is the other crescent: a deviation of the opposite sign, as
// strong as the blob's own, right beside it. An inked disc has none (nothing
// on a print is lighter than its ground, or darker than the ground of light
// discs), nor has a ring. Returns the 99th percentile of the opposite-sign
// deviation from the ground plane within a blob diameter of the blob's
// ellipse, over |delta| (0 when it is within noise). ~1k pixels per disc.
double opposite_deviation(const cv::Mat& lum, const Blob& blob, const Refined& R, bool dark) {
  const Vec2 c = R.centroid, gc = R.gc;
  const std::array<double, 3>& g = R.g;
  const double delta = R.contrast;
  const bool multiplicative = R.multiplicative;
  const auto [l1, l2] = blob.cov.eig();
  const double semi_minor = 2 * std::sqrt(l2), semi_major = 2 * std::sqrt(l1);
  const double rho_f = 1 + (2 * semi_major + 2) / semi_minor;
  const Sym2 Ci = blob.cov.inverse();
  const double ex = 2 * std::sqrt(blob.cov.xx) * rho_f, ey = 2 * std::sqrt(blob.cov.yy) * rho_f;
  const int x0 = std::max(0, static_cast<int>(std::floor(c.x - ex)));
  const int x1 = std::min(lum.cols - 1, static_cast<int>(std::ceil(c.x + ex)));
  const int y0 = std::max(0, static_cast<int>(std::floor(c.y - ey)));
  const int y1 = std::min(lum.rows - 1, static_cast<int>(std::ceil(c.y + ey)));
  // A few hundred samples are enough: large (printed) discs on a grid.
  const int step = std::max(1, static_cast<int>(0.25 * semi_minor));
  std::vector<float> opp, diff;
  for (int y = y0; y <= y1; y += step) {
    const float* row = lum.ptr<float>(y);
    for (int x = x0; x <= x1; x += step) {
      const double r2 = 0.25 * Ci.quad({x - c.x, y - c.y});
      if (r2 <= 1 || r2 > rho_f * rho_f) continue;
      const double gr = g[0] + g[1] * (x - gc.x) + g[2] * (y - gc.y);
      double u = row[x] - gr;
      if (multiplicative) {
        if (!(gr > 0)) continue;
        u *= g[0] / gr;
      }
      opp.push_back(static_cast<float>(dark ? u : -u));
      if (x + 1 < lum.cols) diff.push_back(std::abs(row[x + 1] - row[x]));
    }
  }
  if (opp.size() < 20 || !(std::abs(delta) > 0)) return 0;
  const double peak = percentile_of(opp, 0.99);
  // Noise: the robust spread of neighbouring pixels' differences (the
  // crescents and the ground's gradient are smooth at this scale).
  const double sigma = 1.4826 / std::sqrt(2.0) * percentile_of(diff, 0.5);
  if (!(peak > 4 * sigma)) return 0;
  return peak / std::abs(delta);
}

namespace {

// Where a disc is measured: the window rho <= rho_w, rho the normalised
// radius in the blob's ellipse metric (1 on its moment ellipse: a disc of
// radius R has covariance R^2/4), and around it the annulus
// rho_w < rho <= rho_o that gives the ground plane.
struct CentroidWindow {
  Sym2 Ci;  // the blob's inverse covariance
  double semi_minor = 0;
  double rho_w = 0, rho_o = 0;
  // Half-extents of the ellipse {rho <= 1}: 2 sqrt(C_xx), 2 sqrt(C_yy).
  double ex = 0, ey = 0;
};

// The window must hold the blur tails, and window and annulus stay clear of
// other marks of the same polarity (their tails would pull the centroid).
// nullopt when the nearest mark leaves no room.
std::optional<CentroidWindow> centroid_window(const Blob& blob, const Detection& det, int pol) {
  CentroidWindow w;
  const auto [l1, l2] = blob.cov.eig();
  w.semi_minor = 2 * std::sqrt(l2);
  double margin = std::clamp(0.4 * w.semi_minor + 2.0, 3.0, 15.0);
  double ring = std::clamp(0.3 * w.semi_minor, 2.0, 8.0);
  w.Ci = blob.cov.inverse();
  const double gap = clearance_px(blob, det, pol, margin + ring);
  if (gap < kInf) {
    margin = std::min(margin, 0.4 * gap);
    ring = std::min(ring, std::max(1.5, 0.3 * gap));
    if (margin < 1.5) return std::nullopt;
  }
  w.rho_w = 1 + margin / w.semi_minor;
  w.rho_o = 1 + (margin + ring) / w.semi_minor;
  w.ex = 2 * std::sqrt(blob.cov.xx);
  w.ey = 2 * std::sqrt(blob.cov.yy);
  return w;
}

using WindowPixels = std::vector<std::array<double, 4>>;   // x, y, I, rho^2
using AnnulusPixels = std::vector<std::array<double, 3>>;  // x - c, y - c, I

// The window's pixels around the centre c, and with `annulus` the ground
// annulus's. False if the window leaves the image (a clipped disc has a
// wrong centroid); the annulus may be clipped.
bool sample_window(const cv::Mat& lum, const CentroidWindow& w, Vec2 c, bool annulus,
                   WindowPixels& win, AnnulusPixels& ann) {
  const double rho_w2 = w.rho_w * w.rho_w, rho_o2 = w.rho_o * w.rho_o;
  if (c.x - w.rho_w * w.ex < 0 || c.y - w.rho_w * w.ey < 0 || c.x + w.rho_w * w.ex > lum.cols - 1 ||
      c.y + w.rho_w * w.ey > lum.rows - 1)
    return false;
  const int x0 = std::max(0, static_cast<int>(std::floor(c.x - w.rho_o * w.ex)));
  const int x1 = std::min(lum.cols - 1, static_cast<int>(std::ceil(c.x + w.rho_o * w.ex)));
  const int y0 = std::max(0, static_cast<int>(std::floor(c.y - w.rho_o * w.ey)));
  const int y1 = std::min(lum.rows - 1, static_cast<int>(std::ceil(c.y + w.rho_o * w.ey)));
  ann.clear();
  win.clear();
  for (int y = y0; y <= y1; ++y) {
    const float* row = lum.ptr<float>(y);
    for (int x = x0; x <= x1; ++x) {
      const double r = 0.25 * w.Ci.quad({x - c.x, y - c.y});
      if (r <= rho_w2)
        win.push_back({double(x), double(y), double(row[x]), r});
      else if (annulus && r <= rho_o2)
        ann.push_back({x - c.x, y - c.y, double(row[x])});
    }
  }
  return true;
}

// The ground plane g[0] + g[1] (x - gc.x) + g[2] (y - gc.y) around a disc,
// the disc's ink deviation delta from it, and whether illumination scales
// both (deviations are then divided by the ground's relative level).
struct DiscLevels {
  std::array<double, 3> g{};
  Vec2 gc{};
  double delta = 0;
  bool multiplicative = false;
  double ground(double x, double y) const { return g[0] + g[1] * (x - gc.x) + g[2] * (y - gc.y); }
};

// Ground plane by least squares on the annulus around c, then once more
// without outliers (3.5 robust sigmas): a smooth illumination gradient
// cancels. Sets L.g and L.gc; returns the ground's robust sigma, or nullopt
// when the plane cannot be solved for.
std::optional<double> fit_ground_plane(const AnnulusPixels& ann, Vec2 c, DiscLevels& L,
                                       std::vector<float>& tmp) {
  std::array<double, 3>& g = L.g;
  double sigma = 0;
  std::vector<char> keep(ann.size(), 1);
  for (int pass = 0; pass < 2; ++pass) {
    double M[3][3] = {}, b[3] = {};
    for (size_t i = 0; i < ann.size(); ++i) {
      if (!keep[i]) continue;
      const double f[3] = {1, ann[i][0], ann[i][1]};
      for (int r = 0; r < 3; ++r) {
        b[r] += f[r] * ann[i][2];
        for (int q = 0; q < 3; ++q) M[r][q] += f[r] * f[q];
      }
    }
    const cv::Matx33d Mm(M[0][0], M[0][1], M[0][2], M[1][0], M[1][1], M[1][2], M[2][0], M[2][1],
                         M[2][2]);
    cv::Vec3d sol;
    if (!cv::solve(Mm, cv::Vec3d(b[0], b[1], b[2]), sol, cv::DECOMP_CHOLESKY)) return std::nullopt;
    g = {sol[0], sol[1], sol[2]};
    L.gc = c;
    tmp.clear();
    for (const auto& a : ann)
      tmp.push_back(static_cast<float>(std::abs(a[2] - (g[0] + g[1] * a[0] + g[2] * a[1]))));
    sigma = 1.4826 * percentile_of(tmp, 0.5);
    if (pass == 0)
      for (size_t i = 0; i < ann.size(); ++i)
        keep[i] = std::abs(ann[i][2] - (g[0] + g[1] * ann[i][0] + g[2] * ann[i][1])) <=
                  3.5 * sigma + 1e-30;
  }
  return sigma;
}

// The ink level L.delta: the disc's extreme (2nd percentile), so that
// clamping only clips noise and blurred small discs stay linear. False if
// the disc does not stand out of the ground's noise `sigma`.
bool fit_ink_level(const WindowPixels& win, bool dark, double sigma, DiscLevels& L,
                   std::vector<float>& tmp) {
  const std::array<double, 3>& g = L.g;
  tmp.clear();
  for (const auto& p : win)
    if (p[3] <= 1.0) tmp.push_back(static_cast<float>(p[2] - L.ground(p[0], p[1])));
  if (tmp.size() < 5) return false;
  const double delta0 = percentile_of(tmp, dark ? 0.02 : 0.98);
  // Illumination scales ink and ground alike: where the ground is well
  // above zero, divide the disc's deviation by the ground's relative
  // level (exact for a multiplicative illumination field).
  L.multiplicative = g[0] > 0.25 * std::abs(delta0);
  L.delta = delta0;
  if (L.multiplicative) {
    tmp.clear();
    for (const auto& p : win)
      if (p[3] <= 1.0) {
        const double gr = L.ground(p[0], p[1]);
        if (!(gr > 0)) return false;
        tmp.push_back(static_cast<float>((p[2] - gr) * g[0] / gr));
      }
    L.delta = percentile_of(tmp, dark ? 0.02 : 0.98);
  }
  return !((dark ? -L.delta : L.delta) < std::max(5 * sigma, 1e-12 * std::abs(g[0])));
}

// Sums of the coverage weights w = clamp(u / delta, 0, 1) and of their
// moments about the current centre (no cancellation far from 0).
struct CoverageMoments {
  double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0, syy = 0;
};

// False where a multiplicative ground is not positive.
bool coverage_moments(const WindowPixels& win, Vec2 c, const DiscLevels& L, CoverageMoments& m) {
  const std::array<double, 3>& g = L.g;
  for (const auto& p : win) {
    const double gr = L.ground(p[0], p[1]);
    double u = p[2] - gr;
    if (L.multiplicative) {
      if (!(gr > 0)) return false;
      u *= g[0] / gr;
    }
    const double dx = p[0] - c.x, dy = p[1] - c.y;
    const double wgt = std::clamp(u / L.delta, 0.0, 1.0);
    m.sw += wgt;
    m.sx += wgt * dx;
    m.sy += wgt * dy;
    m.sxx += wgt * dx * dx;
    m.sxy += wgt * dx * dy;
    m.syy += wgt * dy * dy;
  }
  return true;
}

}  // namespace

Refined refine_centroid(const cv::Mat& lum, const Blob& blob, const Detection& det, int pol) {
  const bool dark = pol == kDark;
  Refined out;
  const std::optional<CentroidWindow> window = centroid_window(blob, det, pol);
  if (!window) return out;
  Vec2 c = blob.center;
  WindowPixels win;
  AnnulusPixels ann;
  std::vector<float> tmp;
  DiscLevels L;
  for (int iter = 0; iter < 10; ++iter) {
    // Levels are estimated on the first two passes (the detection centre may
    // be off by a pixel); later passes only re-centre the window.
    const bool levels = iter < 2;
    if (!sample_window(lum, *window, c, levels, win, ann)) return out;
    if (win.size() < 9) return out;
    if (levels) {
      if (ann.size() < 12) return out;
      const std::optional<double> sigma = fit_ground_plane(ann, c, L, tmp);
      if (!sigma || !fit_ink_level(win, dark, *sigma, L, tmp)) return out;
    }
    CoverageMoments m;
    if (!coverage_moments(win, c, L, m)) return out;
    if (!(m.sw > 0)) return out;
    const Vec2 d1{m.sx / m.sw, m.sy / m.sw};
    const Vec2 cn = c + d1;
    out.cov = {m.sxx / m.sw - d1.x * d1.x, m.sxy / m.sw - d1.x * d1.y, m.syy / m.sw - d1.y * d1.y};
    if (norm(cn - blob.center) > 0.5 * window->semi_minor + 1) return out;  // wandered off
    const double step = norm(d1);
    c = cn;
    out.area = m.sw;
    out.contrast = L.delta;
    if (step < 1e-4 && !levels) break;
  }
  out.ok = true;
  out.centroid = c;
  out.ground = L.ground(c.x, c.y);
  out.g = L.g;
  out.gc = L.gc;
  out.multiplicative = L.multiplicative;
  return out;
}

const Refined* RefinedCache::get(int b) {
  if (!done_[b]) {
    r_[b] = pol_ == kShaded ? refine_relief(lum_, det_.blobs[pol_][b], det_)
                            : refine_centroid(lum_, det_.blobs[pol_][b], det_, pol_);
    done_[b] = 1;
  }
  return r_[b].ok ? &r_[b] : nullptr;
}

double RefinedCache::opposite(int b) {
  Refined& R = r_[b];
  if (R.opposite < 0)
    R.opposite =
        pol_ == kShaded ? 0 : opposite_deviation(lum_, det_.blobs[pol_][b], R, pol_ == kDark);
  return R.opposite;
}

}  // namespace tactres::locate_detail
