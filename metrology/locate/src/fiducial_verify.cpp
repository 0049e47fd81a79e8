// Checking one identification hypothesis against the plane map it implies
// (fiducial_verify.h).

#include "fiducial_verify.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "fiducial_light_field.h"

namespace tactres::locate_detail {

// Least-squares affine map (>= 3 points, not all collinear) as a homography.
std::optional<Homography> fit_affine(const std::vector<Vec2>& src, const std::vector<Vec2>& dst) {
  const int n = static_cast<int>(src.size());
  if (n < 3) return std::nullopt;
  Vec2 cs{}, cd{};
  for (int i = 0; i < n; ++i) {
    cs = cs + src[i];
    cd = cd + dst[i];
  }
  cs = (1.0 / n) * cs;
  cd = (1.0 / n) * cd;
  // Normal equations of the centred problem: dst - cd = A (src - cs).
  Sym2 S{};
  double bx[2] = {0, 0}, by[2] = {0, 0};
  for (int i = 0; i < n; ++i) {
    const Vec2 p = src[i] - cs, q = dst[i] - cd;
    S.xx += p.x * p.x;
    S.xy += p.x * p.y;
    S.yy += p.y * p.y;
    bx[0] += p.x * q.x;
    bx[1] += p.y * q.x;
    by[0] += p.x * q.y;
    by[1] += p.y * q.y;
  }
  if (!(S.det() > 1e-9 * S.trace() * S.trace())) return std::nullopt;
  const Sym2 Si = S.inverse();
  const Vec2 ax = Si.mul({bx[0], bx[1]}), ay = Si.mul({by[0], by[1]});
  return Homography{ax.x, ax.y, cd.x - ax.x * cs.x - ax.y * cs.y,
                    ay.x, ay.y, cd.y - ay.x * cs.x - ay.y * cs.y,
                    0,    0,    1};
}

namespace {

// Refined::opposite above which a blob looks like one crescent of a relief.
constexpr double kBipolarOpposite = 0.3;

// Eigenvalues of Q^-1 C, largest first (nullopt if not positive).
std::optional<std::pair<double, double>> relative_eig(const Sym2& Q, const Sym2& C) {
  const Sym2 Qi = Q.inverse();
  const double tr = Qi.xx * C.xx + 2 * Qi.xy * C.xy + Qi.yy * C.yy;
  const double det = C.det() / Q.det();
  const double disc = std::sqrt(std::max(0.0, 0.25 * tr * tr - det));
  const double mu1 = 0.5 * tr + disc, mu2 = 0.5 * tr - disc;
  if (!(mu2 > 0)) return std::nullopt;
  return std::pair{mu1, mu2};
}

}  // namespace

// Relief discs (shaded mode): refine_relief() measured each disc's image
// ellipse, which must be the projected disc P the map predicts, in size
// and shape, to within the tolerances of printed discs. Under a
// directional light every disc shows a light and a dark crescent, whose
// dipole is a good fraction of the disc's radius and points along the
// light's in-plane part at the disc: the same everywhere under one distant
// light, turning over the target under a spot or a lit rim below the gel.
// The directions must follow one such field (fiducial_light_field.h);
// texture has them in unrelated directions. Rings (a diffuse light) have
// no dipole at all; a mix of rings and crescents is no light's.
std::optional<double> HypothesisCheck::relief_shape_score(const std::array<Sym2, 5>& P,
                                                          const std::array<int, 5>& cand,
                                                          bool strict) const {
  const double lens = strict ? 0.0 : 3 * o_.max_fit_error_frac;
  const double tol_shape = std::log(strict ? 1.25 : 1.4) + lens;
  std::vector<Vec2> centres_px, dipoles_px;
  int n = 0, rings = 0;
  for (int k = 0; k < 5; ++k) {
    if (cand[k] < 0) continue;
    ++n;
    const Refined* R = refined_.get(cand[k]);
    const double r_px = 2 * std::sqrt(std::sqrt(P[k].det()));  // sqrt(a b), semi-axes a, b
    if (norm(R->dipole) < 0.15 * r_px) {
      ++rings;
      continue;
    }
    centres_px.push_back(R->centroid);
    dipoles_px.push_back(R->dipole);
  }
  if (rings > 0 && rings < n) return std::nullopt;
  if (rings == 0 && !follows_one_light(light_field_deviation(centres_px, dipoles_px)))
    return std::nullopt;
  double sum = 0;
  for (int k = 0; k < 5; ++k) {
    if (cand[k] < 0) continue;
    const auto mu = relative_eig(P[k], refined_.get(cand[k])->cov);
    if (!mu) return std::nullopt;
    const double dev =
        std::max(std::abs(std::log(mu->first)), std::abs(std::log(mu->second))) / tol_shape;
    if (dev > 1) return std::nullopt;
    sum += dev * dev;
  }
  return sum / n;
}

// Every matched disc's image must be the disc the map predicts there.
// Returns the mean squared normalised deviation, or nullopt if any disc is
// out of tolerance (tighter when `strict`).
// `printed` is set when the discs passed as inked (filled) discs.
std::optional<double> HypothesisCheck::shape_score(const Homography& H,
                                                   const std::array<int, 5>& cand, bool strict,
                                                   bool& printed) const {
  printed = false;
  const double r2 = 0.25 * pat_.r_mm * pat_.r_mm;
  std::array<Sym2, 5> P;
  std::array<double, 5> area_pred{};
  int n = 0;
  bool filled = true;
  double fill = 0;  // mean coverage / outline area
  for (int k = 0; k < 5; ++k) {
    if (cand[k] < 0) continue;
    const MapJacobian J = map_jacobian(H, pat_.p[k]);
    const Sym2 JJ{J.a * J.a + J.b * J.b, J.a * J.c + J.b * J.d, J.c * J.c + J.d * J.d};
    const auto [s1, s2k] = JJ.eig();
    // Foreshortening bound from max_tilt (perspective adds some).
    if (!(s2k > 0) || std::sqrt(s2k / s1) < 0.75 * cos_tilt_) return std::nullopt;
    P[k] = {r2 * JJ.xx, r2 * JJ.xy, r2 * JJ.yy};
    area_pred[k] = kPi * pat_.r_mm * pat_.r_mm * std::abs(J.a * J.d - J.b * J.c);
    // A ring (relief through a gel) covers much less than its outline.
    const double f = refined_.get(cand[k])->area / blobs_[cand[k]].area;
    filled = filled && f >= 0.7;
    fill += f;
    ++n;
  }
  if (shaded_) return relief_shape_score(P, cand, strict);
  double sum = 0;
  if (filled) {
    // Printed discs: the coverage moments are those of the projected disc
    // P = (r^2/4) J J^T plus an isotropic blur s^2 (one for all discs,
    // fitted), and the coverage area is pi r^2 |det J| (blur-invariant).
    // Lens distortion squeezes discs near the image's edge (radially more
    // than tangentially) beyond what the homography predicts: the
    // tolerances grow with the allowed fit error.
    const double lens = strict ? 0.0 : 3 * o_.max_fit_error_frac;
    const double tol_shape = std::log(strict ? 1.25 : 1.4) + lens;
    const double tol_area = std::log(strict ? 1.2 : 1.35) + lens;
    double s2 = 0, s2_max = kInf;
    for (int k = 0; k < 5; ++k) {
      if (cand[k] < 0) continue;
      s2 += std::max(0.0, 0.5 * (refined_.get(cand[k])->cov.trace() - P[k].trace()));
      // Blur wider than the disc's minor semi-axis leaves no disc to measure.
      s2_max = std::min(s2_max, 4 * P[k].eig().second);
    }
    s2 = std::min(s2 / n, s2_max);
    bool fits = true;
    for (int k = 0; k < 5 && fits; ++k) {
      if (cand[k] < 0) continue;
      const Refined* R = refined_.get(cand[k]);
      const auto mu = relative_eig({P[k].xx + s2, P[k].xy, P[k].yy + s2}, R->cov);
      if (!mu) return std::nullopt;
      const double dev =
          std::max(std::abs(std::log(mu->first)), std::abs(std::log(mu->second))) / tol_shape;
      const double adev = std::abs(std::log(R->area / area_pred[k])) / tol_area;
      fits = dev <= 1 && adev <= 1;
      sum += dev * dev + adev * adev;
    }
    if (fits) {
      printed = true;
      return sum / n;
    }
    // A blurred small ring can look filled; with all five discs and a
    // fill short of a crisp disc's, give it the ring test (ring_score). Four
    // discs must pass as printed discs.
    if (strict || fill / n > 0.85) return std::nullopt;
  }
  return ring_score(P, cand, n, strict);
}

// Rings: only the outlines (filled) are comparable. Their size relative
// to the disc depends on the threshold and the ring's width, so one
// common factor kappa is fitted; each outline must then match
// kappa * P, to within the tolerance plus a detection pixel. P: the
// projected discs the map predicts; n: how many discs cand names.
std::optional<double> HypothesisCheck::ring_score(const std::array<Sym2, 5>& P,
                                                  const std::array<int, 5>& cand, int n,
                                                  bool strict) const {
  double sum = 0;
  const double tol_shape = std::log(strict ? 1.3 : 1.5);
  // Outline = the disc grown by a common margin delta (the ring's or
  // crescents' width beyond the edge, at the threshold), fitted.
  double delta = 0, p_min = kInf, p_max = 0, pixel = 1;
  for (int k = 0; k < 5; ++k) {
    if (cand[k] < 0) continue;
    const double pk = 2 * std::sqrt(std::sqrt(P[k].det()));  // sqrt(a b)
    delta += 2 * std::sqrt(std::sqrt(blobs_[cand[k]].cov.det())) - pk;
    p_min = std::min(p_min, pk);
    p_max = std::max(p_max, pk);
    pixel = blobs_[cand[k]].pixel;
  }
  delta /= n;
  if (delta < -0.5 * p_min || delta > 1.5 * p_max + 2 * pixel) return std::nullopt;
  for (int k = 0; k < 5; ++k) {
    if (cand[k] < 0) continue;
    const Blob& b = blobs_[cand[k]];
    // P grown by delta along both axes.
    const auto [l1, l2] = P[k].eig();
    const double th = 0.5 * std::atan2(2 * P[k].xy, P[k].xx - P[k].yy);
    const double g1 = std::pow(std::sqrt(l1) + 0.5 * delta, 2),
                 g2 = std::pow(std::sqrt(l2) + 0.5 * delta, 2);
    const double c = std::cos(th), sn = std::sin(th);
    const Sym2 Q{g1 * c * c + g2 * sn * sn, (g1 - g2) * c * sn, g1 * sn * sn + g2 * c * c};
    const auto mu = relative_eig(Q, b.cov);
    if (!mu) return std::nullopt;
    // One detection pixel on the semi-minor axis, relative.
    const double quant = 2 * b.pixel / (2 * std::sqrt(b.cov.eig().second));
    const double dev =
        std::max(std::abs(std::log(mu->first)), std::abs(std::log(mu->second))) /
        (tol_shape + quant);
    if (dev > 1) return std::nullopt;
    sum += dev * dev;
  }
  return sum / n;
}

// A printed target's reference patch is a large inked square: where the
// map puts it, the image must be at the ink level the discs show (their
// ground and ink levels, interpolated over the target by planes so that
// illumination gradients cancel). Chance arrangements of round blobs have
// no patch there, and with T3 hidden only the right labelling of the four
// corners puts it on the patch.
bool HypothesisCheck::patch_ok(const Homography& H, const std::array<int, 5>& cand) const {
  const RectMm& q = pat_.patch;
  if (!(q.area_mm2() > 0)) return true;  // nothing to check
  // Planes a + b x + c y (target mm) through the discs' ground and ink
  // deviation, least squares.
  double M[3][3] = {}, bg[3] = {}, bd[3] = {};
  for (int k = 0; k < 5; ++k) {
    if (cand[k] < 0) continue;
    const Refined* R = refined_.get(cand[k]);
    const double f[3] = {1, pat_.p[k].x, pat_.p[k].y};
    for (int r = 0; r < 3; ++r) {
      bg[r] += f[r] * R->ground;
      bd[r] += f[r] * R->contrast;
      for (int t = 0; t < 3; ++t) M[r][t] += f[r] * f[t];
    }
  }
  const cv::Matx33d Mm(M[0][0], M[0][1], M[0][2], M[1][0], M[1][1], M[1][2], M[2][0], M[2][1],
                       M[2][2]);
  cv::Vec3d g, d;
  if (!cv::solve(Mm, cv::Vec3d(bg[0], bg[1], bg[2]), g, cv::DECOMP_SVD) ||
      !cv::solve(Mm, cv::Vec3d(bd[0], bd[1], bd[2]), d, cv::DECOMP_SVD))
    return false;
  const cv::Mat& img = refined_.image();
  std::vector<float> ink;
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j) {
      // Inset by 20 %: room for blur, distortion and the map's error.
      const Vec2 mm{q.x0 + (0.2 + 0.15 * i) * q.width_mm(),
                    q.y0 + (0.2 + 0.15 * j) * q.height_mm()};
      const Vec2 px = map_point(H, mm);
      const int x = static_cast<int>(std::lround(px.x)), y = static_cast<int>(std::lround(px.y));
      if (x < 0 || y < 0 || x >= img.cols || y >= img.rows) continue;
      const double gr = g[0] + g[1] * mm.x + g[2] * mm.y;
      const double de = d[0] + d[1] * mm.x + d[2] * mm.y;
      if (std::abs(de) > 0) ink.push_back(static_cast<float>((img.at<float>(y, x) - gr) / de));
    }
  if (ink.size() < 13) return true;  // the patch is out of view: cannot tell
  return percentile_of(ink, 0.5) > 0.5;
}

// The whole field in front of the camera: no fold, no horizon.
bool HypothesisCheck::in_front(const Homography& H) const {
  double w;
  for (const Vec2& p : pat_.field) {
    map_point(H, p, &w);
    if (!(w > 1e-12)) return false;
  }
  for (const Vec2& p : pat_.p) {
    map_point(H, p, &w);
    if (!(w > 1e-12)) return false;
  }
  return true;
}

// With 5 discs, first the blobs' outline centres, a pixel or two off (more
// for shaded outlines), so that hopeless hypotheses cost no refinement:
// true when even they cannot fit a homography within tolerance. amax: the
// largest blob's area.
bool HypothesisCheck::rough_fit_hopeless(const std::vector<Vec2>& src,
                                         const std::array<int, 5>& cand, double amax) const {
  std::vector<Vec2> rough;
  for (int k = 0; k < 5; ++k) rough.push_back(blobs_[cand[k]].center);
  if (const auto H = fit_homography(src, rough)) {
    double ss = 0;
    for (int k = 0; k < 5; ++k) {
      const Vec2 e = map_point(*H, src[k]) - rough[k];
      ss += dot(e, e);
    }
    const double span = norm(map_point(*H, pat_.p[pat_.b]) - map_point(*H, pat_.p[pat_.a]));
    const double slack = 0.5 * std::sqrt(amax / kPi) + 2 * blobs_[cand[0]].pixel;
    if (std::sqrt(ss / 5) > std::max(1.0, o_.max_fit_error_frac * span) + slack) return true;
  }
  return false;
}

// The maps to try from the layout's discs `src` to their centroids `dst`
// (`missing`: the layout disc not found, -1 if none); empty if degenerate.
std::vector<Homography> HypothesisCheck::candidate_maps(const std::vector<Vec2>& src,
                                                        const std::vector<Vec2>& dst,
                                                        int missing) const {
  std::vector<Homography> maps;
  if (src.size() == 4 && (missing == pat_.c || missing == pat_.d)) {
    // Four discs that include the collinear triple fix only a
    // one-parameter family of homographies (the null space of the DLT is
    // two-dimensional); the discs' images (areas, shapes) pick the member.
    const auto sol = homography_dlt(src, dst);
    if (!sol) return maps;
    for (int i = 0; i < 180; ++i) {
      const double th = kPi * i / 180, c = std::cos(th), s = std::sin(th);
      Homography H;
      for (int k = 0; k < 9; ++k) H[k] = c * sol->runner_up[k] + s * sol->least_squares[k];
      maps.push_back(H);
    }
  } else {
    const auto H = fit_homography(src, dst);
    if (!H) return maps;
    maps.push_back(*H);
  }
  return maps;
}

Verdict HypothesisCheck::verify(const std::array<int, 5>& cand) {
  Verdict v;
  v.cand = cand;
  std::vector<Vec2> src, dst;
  int missing = -1;
  double amin = kInf, amax = 0;
  for (int k = 0; k < 5; ++k) {
    if (cand[k] < 0) {
      missing = k;
      continue;
    }
    src.push_back(pat_.p[k]);
    amin = std::min(amin, blobs_[cand[k]].area);
    amax = std::max(amax, blobs_[cand[k]].area);
  }
  v.n = static_cast<int>(src.size());
  if (v.n < 4 || amax > o_.max_area_ratio * amin) return v;
  if (v.n == 5 && rough_fit_hopeless(src, cand, amax)) return v;
  for (int k = 0; k < 5; ++k) {
    if (cand[k] < 0) continue;
    const Refined* R = refined_.get(cand[k]);
    if (!R) return v;
    dst.push_back(R->centroid);
  }
  // Lines stay lines: if the collinear triple is there, it must be
  // collinear to within what lens distortion could bend. (A homography
  // fitted to all five spreads this error over them; checked alone it
  // rejects many chance patterns.)
  if (cand[pat_.a] >= 0 && cand[pat_.m] >= 0 && cand[pat_.b] >= 0) {
    const Vec2 A = refined_.get(cand[pat_.a])->centroid;
    const Vec2 M = refined_.get(cand[pat_.m])->centroid;
    const Vec2 B = refined_.get(cand[pat_.b])->centroid;
    const double L = norm(B - A);
    if (std::abs(cross(B - A, M - A)) / L > std::max(1.0, o_.max_fit_error_frac * L)) return v;
  }
  for (Homography& H : candidate_maps(src, dst, missing)) {
    // The whole field must lie in front of the camera: no fold, no horizon.
    double w;
    map_point(H, pat_.p[0], &w);
    if (w < 0)
      for (double& h : H) h = -h;
    if (!in_front(H)) continue;
    double ss = 0;
    for (int k = 0; k < v.n; ++k) {
      const Vec2 e = map_point(H, src[k]) - dst[k];
      ss += dot(e, e);
    }
    const double rms = std::sqrt(ss / v.n);
    const double span = norm(map_point(H, pat_.p[pat_.b]) - map_point(H, pat_.p[pat_.a]));
    const double tol = std::max(1.0, o_.max_fit_error_frac * span);
    if (rms > tol) continue;
    // Four discs leave little redundancy: demand closer agreement.
    bool printed = false;
    const auto sh = shape_score(H, cand, v.n < 5, printed);
    if (!sh) continue;
    if (printed && !patch_ok(H, cand)) {
      v.seen = true;
      continue;
    }
    const double score = (rms / tol) * (rms / tol) + *sh;
    if (score < v.score) {
      v.ok = true;
      v.H = H;
      v.rms_px = rms;
      v.score = score;
    }
  }
  if (v.ok && !shaded_) {
    int bip = 0;
    for (int k = 0; k < 5; ++k)
      if (cand[k] >= 0 && refined_.opposite(cand[k]) > kBipolarOpposite) ++bip;
    v.bipolar = 2 * bip > v.n;
  }
  return v;
}

// Three discs (for the message only): the collinear triple's spacing, or an
// exact affine map that predicts all three discs' images.
Verdict HypothesisCheck::verify3(const std::array<int, 5>& cand) {
  Verdict v;
  v.cand = cand;
  v.n = 3;
  std::vector<Vec2> src, dst;
  for (int k = 0; k < 5; ++k)
    if (cand[k] >= 0) {
      const Refined* R = refined_.get(cand[k]);
      if (!R) return v;
      src.push_back(pat_.p[k]);
      dst.push_back(R->centroid);
    }
  if (cand[pat_.c] < 0 && cand[pat_.d] < 0) {
    const Vec2 A = refined_.get(cand[pat_.a])->centroid;
    const Vec2 M = refined_.get(cand[pat_.m])->centroid;
    const Vec2 B = refined_.get(cand[pat_.b])->centroid;
    const double t = dot(M - A, B - A) / dot(B - A, B - A);
    const double t0 = norm(pat_.p[pat_.m] - pat_.p[pat_.a]) / pat_.ab_mm;
    v.ok = std::abs(t - t0) < 0.05 &&
           std::abs(cross(B - A, M - A)) / norm(B - A) < 0.02 * norm(B - A) + 1;
    v.score = std::abs(t - t0);
    return v;
  }
  const auto H = fit_affine(src, dst);
  if (!H) return v;
  bool printed = false;
  const auto sh = shape_score(*H, cand, true, printed);
  if (!sh) return v;
  if (printed && !patch_ok(*H, cand)) {
    v.seen = true;
    return v;
  }
  v.ok = true;
  v.H = *H;
  v.score = *sh;
  return v;
}

}  // namespace tactres::locate_detail
