// Shaded discs (a relief seen through a gel) measured at full resolution:
// the centre of the ellipse fitted to WHERE the rim is, not to how bright
// it is (fiducials.h), on a quadratic ground fitted around the disc.

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "fiducials_internal.h"

namespace tactres::locate_detail {

namespace {

// Bilinear interpolation; (x, y) must lie in [0, cols-1] x [0, rows-1].
inline double bilinear(const cv::Mat& m, double x, double y) {
  const int x0 = std::min(static_cast<int>(x), m.cols - 2);
  const int y0 = std::min(static_cast<int>(y), m.rows - 2);
  const double fx = x - x0, fy = y - y0;
  const float* r0 = m.ptr<float>(y0);
  const float* r1 = m.ptr<float>(y0 + 1);
  return (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) +
         fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
}

// The blob's outline and the window around it in which its rim is fitted.
struct RimWindow {
  Vec2 c0;                 // the outline's centre, px
  double a_out, b_out;     // the outline's semi-axes, px
  Sym2 S_out;              // x^T S_out x = 1 on the outline
  double rho_o;            // the window's edge, in outline radii
  double band_in, band_out;  // the rim's band, in outline radii (not ground)
  double ex, ey;           // the window's half-extents, px
};

// nullopt for an outline too thin to fit, too near another mark, or clipped
// by the frame.
std::optional<RimWindow> rim_window(const cv::Mat& lum, const Blob& blob, const Detection& det) {
  RimWindow w;
  const auto [l1, l2] = blob.cov.eig();
  w.a_out = 2 * std::sqrt(l1);
  w.b_out = 2 * std::sqrt(l2);
  const double b_out = w.b_out;
  if (!(b_out >= 2.5)) return std::nullopt;
  const Sym2 Ci = blob.cov.inverse();
  w.S_out = {0.25 * Ci.xx, 0.25 * Ci.xy, 0.25 * Ci.yy};
  w.c0 = blob.center;
  double margin = std::clamp(0.5 * b_out, 4.0, 12.0);
  const double gap = clearance_px(blob, det, kShaded, margin);
  if (gap < kInf) margin = std::min(margin, 0.8 * gap);
  if (margin < 2.5) return std::nullopt;
  // The outline is the rim's outer edge at the detection threshold (closed,
  // hull); the rim's middle lies ~2 px inside it, its inner edge up to ~6 px.
  w.rho_o = 1 + margin / b_out;
  w.band_in = 1 - std::min(7.0, 0.6 * b_out) / b_out;
  w.band_out = 1 + 1.5 / b_out;
  w.ex = w.rho_o * 2 * std::sqrt(blob.cov.xx);
  w.ey = w.rho_o * 2 * std::sqrt(blob.cov.yy);
  const Vec2 c0 = w.c0;
  if (c0.x - w.ex < 1 || c0.y - w.ey < 1 || c0.x + w.ex > lum.cols - 2 || c0.y + w.ey > lum.rows - 2)
    return std::nullopt;  // clipped by the frame
  return w;
}

// The ground around a disc: a quadratic (a plane if the flat top is too
// small to pin the curvature) in coordinates scaled by the outline's size.
struct QuadraticGround {
  std::array<double, 6> gc{};
  double sigma = 0;  // robust sigma of the ground pixels about it
  Vec2 c0;
  double a_out = 1;
  double at(double x, double y) const {
    const double u = (x - c0.x) / a_out, v = (y - c0.y) / a_out;
    return gc[0] + gc[1] * u + gc[2] * v + gc[3] * u * u + gc[4] * u * v + gc[5] * v * v;
  }
};

// Fitted to the disc's flat top and an annulus around it (relief tops are
// flat, so they shade like the ground) by least squares, then again without
// the outliers (3.5 robust sigmas: what is left of the rim, other marks).
std::optional<QuadraticGround> fit_quadratic_ground(const cv::Mat& lum, const RimWindow& w) {
  const Vec2 c0 = w.c0;
  const double a_out = w.a_out, ex = w.ex, ey = w.ey;
  struct Px {
    double x, y, v;
  };
  std::vector<Px> gpx;
  int inner = 0;
  {
    const int x0 = static_cast<int>(std::floor(c0.x - ex)), x1 = static_cast<int>(std::ceil(c0.x + ex));
    const int y0 = static_cast<int>(std::floor(c0.y - ey)), y1 = static_cast<int>(std::ceil(c0.y + ey));
    for (int y = y0; y <= y1; ++y) {
      const float* row = lum.ptr<float>(y);
      for (int x = x0; x <= x1; ++x) {
        const Vec2 d{(x - c0.x) / a_out, (y - c0.y) / a_out};
        const double r = std::sqrt(w.S_out.quad({x - c0.x, y - c0.y}));
        if (r > w.rho_o || (r > w.band_in && r < w.band_out)) continue;
        inner += r <= w.band_in;
        gpx.push_back({d.x, d.y, double(row[x])});
      }
    }
  }
  const int nf = inner >= 20 ? 6 : 3;
  if (static_cast<int>(gpx.size()) < 4 * nf + 8) return std::nullopt;
  QuadraticGround G;
  G.c0 = c0;
  G.a_out = a_out;
  std::array<double, 6>& gc = G.gc;
  std::vector<char> keep(gpx.size(), 1);
  std::vector<float> res;
  std::vector<double> e(gpx.size());
  for (int pass = 0; pass < 2; ++pass) {
    double M[21] = {}, b[6] = {};  // upper triangle, row by row
    for (size_t i = 0; i < gpx.size(); ++i) {
      if (!keep[i]) continue;
      const Px& p = gpx[i];
      const double f[6] = {1, p.x, p.y, p.x * p.x, p.x * p.y, p.y * p.y};
      for (int r = 0, t = 0; r < nf; ++r) {
        b[r] += f[r] * p.v;
        for (int q = r; q < nf; ++q) M[t++] += f[r] * f[q];
      }
    }
    cv::Matx66d Mm = cv::Matx66d::eye();  // unused terms stay 0
    for (int r = 0, t = 0; r < nf; ++r)
      for (int q = r; q < nf; ++q) Mm(r, q) = Mm(q, r) = M[t++];
    cv::Vec6d sol;
    if (!cv::solve(Mm, cv::Vec6d(b), sol, cv::DECOMP_CHOLESKY)) return std::nullopt;
    for (int r = 0; r < 6; ++r) gc[r] = sol[r];
    res.clear();
    for (size_t i = 0; i < gpx.size(); ++i) {
      const Px& p = gpx[i];
      e[i] = p.v - (gc[0] + gc[1] * p.x + gc[2] * p.y + gc[3] * p.x * p.x +
                    gc[4] * p.x * p.y + gc[5] * p.y * p.y);
      if (keep[i]) res.push_back(static_cast<float>(std::abs(e[i])));
    }
    G.sigma = 1.4826 * percentile_of(res, 0.5);
    for (size_t i = 0; i < gpx.size(); ++i) keep[i] = std::abs(e[i]) <= 3.5 * G.sigma + 1e-30;
  }
  return G;
}

// The deviation from the ground on the pixel grid, once, over the window
// and a few pixels more (rays may reach a little past it); divided by the
// ground's relative level where illumination scales rim and ground alike
// (a multiplicative gradient would otherwise weight one side's rim more).
struct DeviationPatch {
  cv::Mat dev;  // CV_32F
  int px0 = 0, py0 = 0;
  // Bilinear; NaN outside the patch.
  double at(double x, double y) const {
    x -= px0;
    y -= py0;
    if (!(x >= 0 && y >= 0 && x <= dev.cols - 1 && y <= dev.rows - 1))
      return std::numeric_limits<double>::quiet_NaN();
    return bilinear(dev, x, y);
  }
};

DeviationPatch deviation_patch(const cv::Mat& lum, const RimWindow& w, const QuadraticGround& G) {
  const Vec2 c0 = w.c0;
  const double ex = w.ex, ey = w.ey;
  const double g0 = G.gc[0];
  // Illumination scales rim and ground alike where the ground is well above
  // zero (see fit_ink_level, fiducial_centroid.cpp).
  bool multiplicative = g0 > 0;
  for (double sx : {-1.0, 1.0})
    for (double sy : {-1.0, 1.0})
      multiplicative = multiplicative && G.at(c0.x + sx * ex, c0.y + sy * ey) > 0.2 * g0;
  DeviationPatch P;
  P.px0 = std::max(0, static_cast<int>(std::floor(c0.x - ex)) - 6);
  P.py0 = std::max(0, static_cast<int>(std::floor(c0.y - ey)) - 6);
  const int px1 = std::min(lum.cols - 1, static_cast<int>(std::ceil(c0.x + ex)) + 6);
  const int py1 = std::min(lum.rows - 1, static_cast<int>(std::ceil(c0.y + ey)) + 6);
  P.dev.create(py1 - P.py0 + 1, px1 - P.px0 + 1, CV_32F);
  for (int y = P.py0; y <= py1; ++y) {
    const float* row = lum.ptr<float>(y);
    float* out_row = P.dev.ptr<float>(y - P.py0);
    for (int x = P.px0; x <= px1; ++x) {
      const double g = G.at(x, y);
      const double u = row[x] - g;
      out_row[x - P.px0] = static_cast<float>(multiplicative ? u * g0 / std::max(g, 0.05 * g0) : u);
    }
  }
  return P;
}

// Where the rim is, relative to the outline: the peak of the mean
// |deviation| over ellipses concentric with the outline. The outline is
// only roughly the rim's outer edge (a strong rim's tails pass the
// detection threshold farther out, a closing may add a bridge), so this,
// not the outline, starts the fit. nullopt when no ring stands out.
std::optional<double> rim_shrink(const RimWindow& w, const DeviationPatch& dev) {
  const Vec2 c0 = w.c0;
  const double ex = w.ex, ey = w.ey, rho_o = w.rho_o;
  constexpr int kBins = 48;
  std::array<double, kBins> acc{}, cnt{};
  const int x0 = static_cast<int>(std::floor(c0.x - ex)), x1 = static_cast<int>(std::ceil(c0.x + ex));
  const int y0 = static_cast<int>(std::floor(c0.y - ey)), y1 = static_cast<int>(std::ceil(c0.y + ey));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const double r = std::sqrt(w.S_out.quad({x - c0.x, y - c0.y}));
      if (r >= rho_o) continue;
      const int k = static_cast<int>(r / rho_o * kBins);
      acc[k] += std::abs(dev.at(x, y));
      cnt[k] += 1;
    }
  int kp = -1;
  double best = 0;
  for (int k = 0; k < kBins; ++k) {
    if (cnt[k] < 4 || (k + 0.5) * rho_o / kBins < 0.3) continue;  // not the middle
    if (acc[k] / cnt[k] > best) {
      best = acc[k] / cnt[k];
      kp = k;
    }
  }
  if (kp < 0) return std::nullopt;
  double sw = 0, swr = 0;
  for (int k = std::max(0, kp - 2); k <= std::min(kBins - 1, kp + 2); ++k) {
    if (cnt[k] < 1) continue;
    const double m = acc[k] / cnt[k];
    sw += m;
    swr += m * (k + 0.5) * rho_o / kBins;
  }
  return swr / sw;
}

// One pass of the rim fit's rays: the weighted normal equations of the
// conic A x^2 + B x y + C y^2 + D x + E y = 1 through the rim points (in
// units of `scale` about the current centre) and what the pass says about
// the rim.
struct RayPass {
  double N[5][5] = {}, rhs[5] = {};
  double spread = 0, total = 0, sum_abs = 0, w_max = 0;
  Vec2 dip{};
  std::vector<double> ray_w;  // each ray's weight
};

// Along n_rays rays from the centre c through the current ellipse S, each
// within hw px of it: the centroid of the soft-thresholded |deviation|
// (above t) is a point of the disc's edge. Each ray's peak |deviation| is
// appended to `peaks`. False if a ray leaves the deviation patch (the
// ellipse grew past the window).
bool cast_rays(const DeviationPatch& dev, Vec2 c, const Sym2& S, double scale, double hw,
               double t, int n_rays, RayPass& P, std::vector<float>& peaks) {
  constexpr double kStep = 0.5;  // px along each ray
  // M maps the unit circle onto the current ellipse.
  const Sym2 M = S.inv_sqrt();
  P.ray_w.assign(n_rays, 0);
  for (int k = 0; k < n_rays; ++k) {
    const double th = 2 * kPi * k / n_rays;
    const Vec2 p = M.mul({std::cos(th), std::sin(th)});
    const double rk = norm(p);
    const Vec2 e = (1 / rk) * p;
    const double h = std::min(hw, 0.6 * rk);
    double sw = 0, swd = 0, swdd = 0, peak = 0;
    for (double d = -h; d <= h + 1e-9; d += kStep) {
      const Vec2 q = c + (rk + d) * e;
      const double u = dev.at(q.x, q.y);
      if (std::isnan(u)) return false;
      const double w = std::max(std::abs(u) - t, 0.0);
      sw += w;
      swd += w * d;
      swdd += w * d * d;
      peak = std::max(peak, std::abs(u));
      P.sum_abs += std::abs(u);
      P.dip = P.dip + u * ((rk + d) * e);
    }
    peaks.push_back(static_cast<float>(peak));
    if (!(sw > 0)) continue;
    const double dm = swd / sw;
    P.spread += swdd - sw * dm * dm;
    P.total += sw;
    P.ray_w[k] = sw;
    P.w_max = std::max(P.w_max, sw);
    const Vec2 x = (1 / scale) * ((rk + dm) * e);
    const double f[5] = {x.x * x.x, x.x * x.y, x.y * x.y, x.x, x.y};
    for (int r = 0; r < 5; ++r) {
      P.rhs[r] += sw * f[r];
      for (int q = 0; q < 5; ++q) P.N[r][q] += sw * f[r] * f[q];
    }
  }
  return true;
}

// The ellipse x^T S x = 1 about centre + step that the pass's conic
// describes; nullopt if it is no ellipse.
struct ConicEllipse {
  Vec2 step;  // from the current centre, px
  Sym2 S;
};

std::optional<ConicEllipse> solve_conic(const RayPass& P, double scale) {
  cv::Matx<double, 5, 5> Nm;
  cv::Vec<double, 5> bm, sol;
  for (int r = 0; r < 5; ++r) {
    bm[r] = P.rhs[r];
    for (int q = 0; q < 5; ++q) Nm(r, q) = P.N[r][q];
  }
  if (!cv::solve(Nm, bm, sol, cv::DECOMP_SVD)) return std::nullopt;
  const double A = sol[0], B = sol[1], C = sol[2], D = sol[3], E = sol[4];
  const double det2 = 4 * A * C - B * B;
  if (!(A > 0 && C > 0 && det2 > 0)) return std::nullopt;
  const Vec2 x0{(-2 * C * D + B * E) / det2, (B * D - 2 * A * E) / det2};
  const double F0 = A * x0.x * x0.x + B * x0.x * x0.y + C * x0.y * x0.y + D * x0.x + E * x0.y - 1;
  if (!(F0 < 0)) return std::nullopt;
  const double k2 = -F0 * scale * scale;
  return ConicEllipse{scale * x0, Sym2{A / k2, 0.5 * B / k2, C / k2}};
}

}  // namespace

// Sub-pixel centre of a relief disc seen through a gel: a thin outline (a
// light and a dark crescent under a directional light; a ring under a
// diffuse one) on a smoothly lit ground.
//
// Weighting the outline's pixels by |I - ground| is biased: under full
// Lambert shading the dark crescent is stronger and more concentrated than
// the light one (a slope s dims the ground by s cos(el) + s^2 sin(el) / 2),
// and under perspective the near side's rim is wider. What stays symmetric
// is WHERE the rim is: across the edge, |I - ground| is a bump centred on
// the edge whatever its height (any function of the edge's slope profile,
// which the gel and the optics blur symmetrically). So: along rays from the
// current centre, the bump's centroid gives a point of the disc's edge;
// a weighted conic through those points is the disc's image ellipse, and
// its centre is the projected disc's area centroid (exact for a projective
// view: the image of a circle is an ellipse). Iterated until the centre
// settles; each ray's window is re-centred on the current ellipse, so a
// bump cut by the window's end is pulled back on the next pass.
//
// The ground is a quadratic fitted to the disc's flat top and an annulus
// around it (relief tops are flat, so they shade like the ground), robustly.
// Deviations are divided by the ground's relative level: a multiplicative
// illumination gradient would otherwise weight one side's rim more.
Refined refine_relief(const cv::Mat& lum, const Blob& blob, const Detection& det) {
  Refined out;
  const std::optional<RimWindow> window = rim_window(lum, blob, det);
  if (!window) return out;
  const RimWindow& w = *window;
  const std::optional<QuadraticGround> ground = fit_quadratic_ground(lum, w);
  if (!ground) return out;
  const DeviationPatch dev = deviation_patch(lum, w, *ground);
  // Soft threshold: noise alone adds weight everywhere in the ray's window,
  // which would pull each rim point toward the window's middle.
  const double t = 2 * ground->sigma;
  const std::optional<double> shrink = rim_shrink(w, dev);
  if (!shrink) return out;

  const double a_out = w.a_out, b_out = w.b_out;
  const double s2 = *shrink * *shrink;
  Vec2 c = w.c0;
  Sym2 S{w.S_out.xx / s2, w.S_out.xy / s2, w.S_out.yy / s2};
  double hw = std::clamp(0.35 * b_out, 2.0, 5.0);  // half-width of each ray's window, px
  const int n_rays = std::clamp(static_cast<int>(2 * kPi * std::sqrt(a_out * b_out) / 1.5), 24, 256);
  bool converged = false;
  double last_step = kInf;
  std::vector<float> peaks;
  for (int iter = 0; iter < 12 && !converged; ++iter) {
    const double scale = std::sqrt(std::sqrt(1 / S.det()));  // sqrt(a b), for conditioning
    RayPass P;
    peaks.clear();
    if (!cast_rays(dev, c, S, scale, hw, t, n_rays, P, peaks)) return out;
    // The outline must be there on most of its way round (crescents fade
    // only near the two points where the edge runs along the light).
    int rays_on = 0;
    for (double wk : P.ray_w) rays_on += wk > 0.1 * P.w_max;
    if (!(P.w_max > 0) || rays_on < 0.4 * n_rays) return out;
    const std::optional<ConicEllipse> E = solve_conic(P, scale);
    if (!E) return out;
    // The rim's ellipse stays near the outline's.
    const auto [s1, s2k] = E->S.eig();
    if (!(s2k > 0) || 1 / std::sqrt(s2k) > 1.5 * a_out || 1 / std::sqrt(s1) < 0.3 * b_out) return out;
    c = c + E->step;
    S = E->S;
    if (norm(c - w.c0) > 0.5 * b_out + 1) return out;  // wandered off
    const double sd = std::sqrt(std::max(P.spread, 0.0) / P.total);
    hw = std::clamp(2 * sd + 1, 2.0, std::max(2.0, 0.5 / std::sqrt(s1)));
    converged = iter >= 2 && norm(E->step) < 1e-3;
    last_step = norm(E->step);
    out.dipole = (1 / std::max(P.sum_abs, 1e-300)) * P.dip;
  }
  if (last_step > 0.01) return out;  // still moving: no stable rim
  out.ok = true;
  out.centroid = c;
  const Sym2 Sinv = S.inverse();
  out.cov = {0.25 * Sinv.xx, 0.25 * Sinv.xy, 0.25 * Sinv.yy};
  out.area = kPi / std::sqrt(S.det());
  out.contrast = percentile_of(peaks, 0.9);
  out.ground = ground->gc[0];
  return out;
}

}  // namespace tactres::locate_detail
