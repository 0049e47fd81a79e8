#include "tactres/locate/fiducials.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

namespace tactres {

void FiducialSearchOptions::validate() const {
  if (!(min_radius_px > 1.0 && min_radius_px <= 1000.0))
    throw std::invalid_argument(
        fmt::format("fiducial min_radius_px must be in (1, 1000] px, got {}", min_radius_px));
  if (!(max_tilt_deg >= 0.0 && max_tilt_deg <= 80.0))
    throw std::invalid_argument(
        fmt::format("fiducial max_tilt_deg must be in [0, 80] degrees, got {}", max_tilt_deg));
  if (!(max_area_ratio >= 1.5 && max_area_ratio <= 100.0))
    throw std::invalid_argument(
        fmt::format("fiducial max_area_ratio must be in [1.5, 100], got {}", max_area_ratio));
  if (!(max_fit_error_frac > 0.0 && max_fit_error_frac <= 0.2))
    throw std::invalid_argument(
        fmt::format("fiducial max_fit_error_frac must be in (0, 0.2], got {}", max_fit_error_frac));
  if (max_candidates < 5 || max_candidates > 1000)
    throw std::invalid_argument(
        fmt::format("fiducial max_candidates must be in [5, 1000], got {}", max_candidates));
}

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kInf = std::numeric_limits<double>::infinity();

// ---------------------------------------------------------------------------
// Small linear algebra.

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

struct Mat2 {
  double a = 0, b = 0, c = 0, d = 0;  // [[a b] [c d]]
};

using H3 = std::array<double, 9>;

Vec2 map_point(const H3& H, Vec2 p, double* w_out = nullptr) {
  const double w = H[6] * p.x + H[7] * p.y + H[8];
  if (w_out) *w_out = w;
  return {(H[0] * p.x + H[1] * p.y + H[2]) / w, (H[3] * p.x + H[4] * p.y + H[5]) / w};
}

Mat2 jacobian(const H3& H, Vec2 p) {
  const double w = H[6] * p.x + H[7] * p.y + H[8];
  const Vec2 q = map_point(H, p);
  return {(H[0] - q.x * H[6]) / w, (H[1] - q.x * H[7]) / w, (H[3] - q.y * H[6]) / w,
          (H[4] - q.y * H[7]) / w};
}

// Hartley-normalised DLT. Returns the right singular vectors of the two
// smallest singular values, de-normalised to homographies, and those values
// relative to the largest.
struct DltSolution {
  std::array<H3, 2> H;  // H[1]: the least-squares solution; H[0]: the runner-up
  double sv7 = 0, sv8 = 0;
};

std::optional<DltSolution> dlt(const std::vector<Vec2>& src, const std::vector<Vec2>& dst) {
  const int n = static_cast<int>(src.size());
  if (n < 4) return std::nullopt;
  auto normaliser = [](const std::vector<Vec2>& p) {
    Vec2 c{};
    for (const Vec2& q : p) c = c + q;
    c = (1.0 / p.size()) * c;
    double d = 0;
    for (const Vec2& q : p) d += norm(q - c);
    d /= p.size();
    const double s = d > 0 ? std::sqrt(2.0) / d : 1.0;
    return std::array<double, 3>{s, c.x, c.y};  // x' = s (x - c)
  };
  const auto ns = normaliser(src), nd = normaliser(dst);
  cv::Mat A = cv::Mat::zeros(std::max(2 * n, 9), 9, CV_64F);
  for (int i = 0; i < n; ++i) {
    const double x = ns[0] * (src[i].x - ns[1]), y = ns[0] * (src[i].y - ns[2]);
    const double u = nd[0] * (dst[i].x - nd[1]), v = nd[0] * (dst[i].y - nd[2]);
    double* r0 = A.ptr<double>(2 * i);
    double* r1 = A.ptr<double>(2 * i + 1);
    const double a0[9] = {x, y, 1, 0, 0, 0, -u * x, -u * y, -u};
    const double a1[9] = {0, 0, 0, x, y, 1, -v * x, -v * y, -v};
    std::copy(a0, a0 + 9, r0);
    std::copy(a1, a1 + 9, r1);
  }
  cv::Mat w, u, vt;
  cv::SVD::compute(A, w, u, vt, cv::SVD::FULL_UV);
  DltSolution sol;
  const double w0 = w.at<double>(0);
  if (!(w0 > 0)) return std::nullopt;
  sol.sv7 = w.at<double>(7) / w0;
  sol.sv8 = w.rows > 8 ? w.at<double>(8) / w0 : 0.0;
  // H = Td^-1 * Hn * Ts with Ts = [s 0 -s cx; 0 s -s cy; 0 0 1]. The map is
  // linear in Hn, so the pair keeps spanning the same family. Both keep the
  // normalised vectors' unit norm (no rescaling: mixtures stay meaningful).
  const double ss = ns[0], sd = nd[0];
  const double Ts[9] = {ss, 0, -ss * ns[1], 0, ss, -ss * ns[2], 0, 0, 1};
  const double Tdi[9] = {1 / sd, 0, nd[1], 0, 1 / sd, nd[2], 0, 0, 1};
  for (int which = 0; which < 2; ++which) {
    const double* h = vt.ptr<double>(7 + which);
    double M[9];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) {
        M[3 * r + c] = 0;
        for (int k = 0; k < 3; ++k) M[3 * r + c] += h[3 * r + k] * Ts[3 * k + c];
      }
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) {
        double& R = sol.H[which][3 * r + c];
        R = 0;
        for (int k = 0; k < 3; ++k) R += Tdi[3 * r + k] * M[3 * k + c];
      }
    for (double x : sol.H[which])
      if (!std::isfinite(x)) return std::nullopt;
  }
  return sol;
}

// Exact for 4 points in general position, algebraic least squares for more.
// nullopt if degenerate (no clear null direction).
std::optional<H3> fit_homography(const std::vector<Vec2>& src, const std::vector<Vec2>& dst) {
  const auto sol = dlt(src, dst);
  if (!sol || !(sol->sv7 > 1e-9)) return std::nullopt;
  return sol->H[1];
}

// Least-squares affine map (>= 3 points, not all collinear) as a homography.
std::optional<H3> fit_affine(const std::vector<Vec2>& src, const std::vector<Vec2>& dst) {
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
  return H3{ax.x, ax.y, cd.x - ax.x * cs.x - ax.y * cs.y,
            ay.x, ay.y, cd.y - ay.x * cs.x - ay.y * cs.y,
            0,    0,    1};
}

// ---------------------------------------------------------------------------
// The layout's fiducial pattern.

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

// (det C)^(1/4), in mm, of the artwork's outlines (every edge of every
// shape, weighted by its length); 0 if there are none.
double outline_spread_mm(const TargetLayout& layout) {
  double L = 0;
  Vec2 S{};
  Sym2 Q{};
  auto segment = [&](Vec2 a, Vec2 b) {
    // Integrals of p and p p^T along the segment a -> b.
    const Vec2 d = b - a;
    const double l = norm(d);
    if (!(l > 0)) return;
    L += l;
    S = S + (0.5 * l) * (a + b);
    Q.xx += l * (a.x * a.x + a.x * d.x + d.x * d.x / 3);
    Q.xy += l * (a.x * a.y + 0.5 * (a.x * d.y + d.x * a.y) + d.x * d.y / 3);
    Q.yy += l * (a.y * a.y + a.y * d.y + d.y * d.y / 3);
  };
  auto outline = [&](const std::vector<Vec2>& p) {
    for (size_t i = 0; i < p.size(); ++i) segment(p[i], p[(i + 1) % p.size()]);
  };
  for (const ArtworkShape& a : layout.artwork) {
    switch (a.kind) {
      case ArtworkShape::Kind::rect: {
        const RectMm& r = a.rect_mm;
        outline({{r.x0, r.y0}, {r.x1, r.y0}, {r.x1, r.y1}, {r.x0, r.y1}});
        break;
      }
      case ArtworkShape::Kind::disc: {
        std::vector<Vec2> p;
        for (int k = 0; k < 32; ++k)
          p.push_back(a.center_mm + a.radius_mm * Vec2{std::cos(2 * kPi * k / 32), std::sin(2 * kPi * k / 32)});
        outline(p);
        break;
      }
      case ArtworkShape::Kind::polygon:
        outline(a.polygon_mm);
        break;
    }
  }
  if (!(L > 0)) return 0;
  const Vec2 m = (1 / L) * S;
  const Sym2 C{Q.xx / L - m.x * m.x, Q.xy / L - m.x * m.y, Q.yy / L - m.y * m.y};
  return C.det() > 0 ? std::sqrt(std::sqrt(C.det())) : 0;
}

Pattern make_pattern(const TargetLayout& layout) {
  const auto& f = layout.fiducials;
  const std::string hint =
      "the layout's fiducials must be the 5 equal discs TL, T3, TR, BL, BR written by `tactres "
      "generate`";
  if (f.size() != 5)
    throw std::invalid_argument(
        fmt::format("layout has {} fiducials, expected 5: {}", f.size(), hint));
  Pattern P;
  P.r_mm = f[0].radius_mm;
  for (const Fiducial& q : f) {
    if (!(q.radius_mm > 0) || std::abs(q.radius_mm - P.r_mm) > 1e-9 * P.r_mm)
      throw std::invalid_argument("layout fiducials have unequal or non-positive radii: " + hint);
    P.p.push_back(q.center_mm);
    P.id.push_back(q.id);
  }
  int found = 0;
  for (int i = 0; i < 5; ++i)
    for (int k = i + 1; k < 5; ++k)
      for (int j = 0; j < 5; ++j) {
        if (j == i || j == k) continue;
        const Vec2 ik = P.p[k] - P.p[i], ij = P.p[j] - P.p[i];
        const double L2 = dot(ik, ik);
        const double t = dot(ij, ik) / L2;
        if (std::abs(cross(ik, ij)) <= 1e-6 * L2 && t > 0.01 && t < 0.99) {
          ++found;
          if (std::abs(t - 0.5) < 0.05)
            throw std::invalid_argument(
                "layout's collinear fiducial triple has its middle disc at the midpoint, so its "
                "ends cannot be told apart: " +
                hint);
          P.m = j;
          P.a = t < 0.5 ? i : k;
          P.b = t < 0.5 ? k : i;
        }
      }
  if (found != 1)
    throw std::invalid_argument(fmt::format(
        "layout's fiducials contain {} collinear triples, expected exactly 1: {}", found, hint));
  std::vector<int> rest;
  for (int i = 0; i < 5; ++i)
    if (i != P.a && i != P.m && i != P.b) rest.push_back(i);
  const bool first_nearer = norm(P.p[rest[0]] - P.p[P.a]) < norm(P.p[rest[1]] - P.p[P.a]);
  P.c = first_nearer ? rest[0] : rest[1];
  P.d = first_nearer ? rest[1] : rest[0];
  P.field = {Vec2{0, 0}, Vec2{layout.width_mm, 0}, Vec2{layout.width_mm, layout.height_mm},
             Vec2{0, layout.height_mm}};
  P.ab_mm = norm(P.p[P.b] - P.p[P.a]);
  P.patch = layout.reference_patch_mm;
  const double spread = outline_spread_mm(layout);
  P.disc_per_spread = spread > 0 ? P.r_mm / spread : 0;
  return P;
}

// ---------------------------------------------------------------------------
// Candidate blobs.

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
constexpr int kDark = 0, kLight = 1, kShaded = 2;

struct Detection {
  int scale = 1;
  // Per mode (kDark, kLight, kShaded): every outer contour (for the
  // foreign-ink guard of the centroid window) and the disc-like blobs among
  // them.
  std::array<std::vector<std::vector<cv::Point>>, 3> contours;
  std::array<std::vector<cv::Rect>, 3> rects;
  std::array<std::vector<Blob>, 3> blobs;
};

double percentile_of(std::vector<float>& v, double q) {
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

std::vector<float> sample_pixels(const cv::Mat& m, int target_count) {
  const double step = std::max(1.0, std::sqrt(double(m.total()) / target_count));
  std::vector<float> v;
  v.reserve(target_count + m.rows + m.cols);
  for (double y = 0.5 * step; y < m.rows; y += step) {
    const float* row = m.ptr<float>(static_cast<int>(y));
    for (double x = 0.5 * step; x < m.cols; x += step) v.push_back(row[static_cast<int>(x)]);
  }
  return v;
}

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

Workspace& workspace() {
  thread_local Workspace w;
  return w;
}

// A background-normalised copy of the image at one detection scale.
struct Normalised {
  bool blank = true;
  cv::Mat n;         // log(I) - its local mean
  cv::Mat n8;        // n mapped to 8 bits, 0 at 127.5
  double otsu = 0;   // Otsu threshold of n8
  double sn = 0;     // robust maximum of |n|
  double noise = 0;  // robust standard deviation of n
};

Normalised normalise(const cv::Mat& img) {
  Normalised out;
  std::vector<float> s = sample_pixels(img, 5000);
  const double lo = percentile_of(s, 0.005), hi = percentile_of(s, 0.995);
  if (!(hi - lo > 1e-12 * std::max(1.0, std::abs(hi)))) return out;  // blank image
  // Log of luminance minus its local (geometric) mean: multiplicative
  // illumination gradients and vignetting cancel, and both polarities are
  // symmetric around 0. The offset keeps a dark ground's noise from exploding.
  const float base = static_cast<float>(std::min(lo, 0.0));
  const float eps = static_cast<float>(0.01 * (hi - base));
  // One buffer, transformed in place (see Workspace).
  Workspace& ws = workspace();
  cv::Mat& L = ws.log_img;
  L.create(img.size(), CV_32F);
  for (int y = 0; y < img.rows; ++y) {
    const float* src = img.ptr<float>(y);
    float* dst = L.ptr<float>(y);
    for (int x = 0; x < img.cols; ++x) dst[x] = std::max(src[x] - base, 0.0f) + eps;
  }
  cv::log(L, L);
  // The box must be several disc diameters wide: a disc of a target that
  // fills the image is ~6 % of its height across.
  int k = static_cast<int>(0.2 * std::min(img.cols, img.rows)) | 1;
  k = std::max(k, 15);
  cv::Mat& B = ws.log_mean;
  cv::blur(L, B, cv::Size(k, k), cv::Point(-1, -1), cv::BORDER_REFLECT);
  cv::subtract(L, B, L);
  out.n = L;
  std::vector<float> an = sample_pixels(out.n, 5000);
  for (float& x : an) x = std::abs(x);
  out.sn = std::max(percentile_of(an, 0.998), 0.05);
  out.noise = 1.4826 * percentile_of(an, 0.5);  // most pixels are ground
  out.n.convertTo(ws.n8, CV_8U, 127.5 / out.sn, 127.5);
  out.n8 = ws.n8;
  // Nothing stands out of the noise (a blank or defocused view): thresholds
  // would only cut the noise into countless specks.
  if (out.sn < 6 * out.noise) return out;
  out.otsu =
      cv::threshold(out.n8, ws.otsu_scratch, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
  out.blank = false;
  return out;
}

// Where a relief seen through a gel shows its edges. Under a directional
// light (linearised Lambert) the image is proportional to the surface slope
// along the light, so a raised disc shows only a thin light and a thin dark
// crescent on a ground that a strongly non-uniform illumination (diffuser
// spot, vignetting, hot spots) makes vary far more than the crescents do.
// A global normalisation (normalise() above) cannot threshold that: its
// noise is that of the darkest corners. Here the deviation from a local
// background (a band-pass: edges ~1-3 px wide pass, illumination does not)
// is tested against the noise expected AT THAT BACKGROUND LEVEL, measured
// from the image itself (shot noise grows with the level, read noise does
// not). Both signs count: light and dark crescents alike, and rings.
struct ReliefMask {
  bool blank = true;
  cv::Mat mask;  // CV_8U, 255 where the deviation is significant
};

// A smooth background at ~4 px: the mean over 4x4 blocks, a 3x3 box on
// that grid, bilinear back up (~4 px Gaussian overall, and ~3x cheaper than
// two 9x9 boxes at full size). `small` receives the block grid.
void smooth_background(const cv::Mat& img, cv::Mat& small, cv::Mat& bg) {
  const cv::Size s((img.cols + 3) / 4, (img.rows + 3) / 4);
  cv::resize(img, small, s, 0, 0, cv::INTER_AREA);
  cv::blur(small, small, cv::Size(3, 3), cv::Point(-1, -1), cv::BORDER_REFLECT);
  cv::resize(small, bg, img.size(), 0, 0, cv::INTER_LINEAR);
}

ReliefMask relief_mask(const cv::Mat& img) {
  ReliefMask out;
  if (std::min(img.cols, img.rows) < 16) return out;
  // Slight smoothing (3x3 binomial), about the width of a blurred edge's
  // slope: it halves the noise and keeps the crescents. The background is
  // wide against a crescent, narrow against any illumination feature.
  Workspace& ws = workspace();
  cv::Mat &fine = ws.fine, &bg = ws.bg, &small = ws.small;
  cv::GaussianBlur(img, fine, cv::Size(3, 3), 0, 0, cv::BORDER_REFLECT);
  smooth_background(img, small, bg);

  // Noise versus background level, from a sample: binned by level, and in
  // each bin a low quantile of |fine - bg| (most pixels are flat ground;
  // edges sit in the upper tail). q25 of |N(0, s)| is 0.3186 s.
  double lo = kInf, hi = -kInf;
  for (int y = 0; y < small.rows; ++y) {
    const float* p = small.ptr<float>(y);
    for (int x = 0; x < small.cols; ++x) {
      lo = std::min(lo, double(p[x]));
      hi = std::max(hi, double(p[x]));
    }
  }
  if (!(hi - lo > 1e-12 * std::max(1.0, std::abs(hi)))) return out;  // blank image
  constexpr int kBins = 16;
  std::array<std::vector<float>, kBins> bins;
  std::array<double, kBins> level_sum{};
  {
    const int step = std::max(1, static_cast<int>(std::sqrt(double(img.total()) / 8000)));
    for (int y = step / 2; y < img.rows; y += step) {
      const float* pb = bg.ptr<float>(y);
      const float* pf = fine.ptr<float>(y);
      for (int x = step / 2; x < img.cols; x += step) {
        const int k = std::clamp(static_cast<int>((pb[x] - lo) / (hi - lo) * kBins), 0, kBins - 1);
        bins[k].push_back(std::abs(pf[x] - pb[x]));
        level_sum[k] += pb[x];
      }
    }
  }
  // The photon-transfer model var = a + b level (read noise, shot noise),
  // fitted to the bins weighted by their pixel counts: a bin made mostly of
  // edges (a level that only occurs beside strong edges, as in a uniformly
  // lit capture) then cannot raise the threshold at its level.
  size_t total = 0;
  for (const auto& bin : bins) total += bin.size();
  double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (int k = 0; k < kBins; ++k) {
    if (bins[k].size() < std::max<size_t>(40, total / 50)) continue;
    const double w = bins[k].size(), x = level_sum[k] / bins[k].size();
    const double sd = percentile_of(bins[k], 0.25) / 0.3186;
    sw += w;
    sx += w * x;
    sy += w * sd * sd;
    sxx += w * x * x;
    sxy += w * x * sd * sd;
  }
  if (!(sw > 0)) return out;
  double var_b = (sw * sxy - sx * sy) / std::max(sw * sxx - sx * sx, 1e-300);
  double var_a = (sy - var_b * sx) / sw;
  if (!(var_b > 0)) {
    var_b = 0;
    var_a = sy / sw;
  } else if (var_a < 0) {
    var_a = 0;
    var_b = sxy / std::max(sxx, 1e-300);
  }
  // Threshold per background level: 4 sigma of the noise, and never below
  // 2 % of the level (a noise-free render has no noise to set the
  // threshold, only numerical ripple) nor 0.1 % of the range. Evaluated on
  // the block grid and brought up like the background (it is as smooth).
  constexpr double kSigmas = 4.0, kMinContrast = 0.02;
  const double floor_abs = 1e-3 * (std::abs(hi) + std::abs(lo));
  auto threshold_at = [&](double g) {
    const double sd = std::sqrt(std::max(0.0, var_a + var_b * g));
    return std::max({kSigmas * sd, kMinContrast * std::abs(g), floor_abs});
  };
  cv::Mat &thr_small = ws.thr_small, &thr = ws.thr;
  thr_small.create(small.size(), CV_32F);
  for (int y = 0; y < small.rows; ++y) {
    const float* p = small.ptr<float>(y);
    float* q = thr_small.ptr<float>(y);
    for (int x = 0; x < small.cols; ++x) q[x] = static_cast<float>(threshold_at(p[x]));
  }
  cv::resize(thr_small, thr, img.size(), 0, 0, cv::INTER_LINEAR);

  // A strong edge raises the background around it (by up to ~1/4 of its
  // peak), so the deviation shows side lobes of the other sign up to ~8 px
  // either side, which pass the threshold too: a disc's outline would grow
  // by several pixels and merge with specks around it. So the significant
  // pixels (and their neighbours) are replaced by the background and the
  // background is taken again: the lobes drop ~4x, and a linear
  // illumination ramp is left as it was.
  cv::Mat &mag = ws.mag, &edges = ws.edges, &patched = ws.patched;
  cv::absdiff(fine, bg, mag);
  cv::compare(mag, thr, edges, cv::CMP_GT);
  cv::dilate(edges, edges, cv::Mat());  // 3x3
  img.copyTo(patched);
  bg.copyTo(patched, edges);
  smooth_background(patched, small, bg);
  cv::absdiff(fine, bg, mag);
  // What remains of the lobes (a few % of the edge's peak) can still pass
  // the noise threshold beside a strong edge: pixels below 15 % of the
  // strongest deviation within the background's reach (8 px) are left out.
  // (A disc's rim loses only where it runs within ~10 degrees of the light.)
  cv::Mat& local_max = patched;  // reused
  cv::dilate(mag, local_max, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(17, 17)));
  local_max *= 0.15;
  cv::max(thr, local_max, thr);
  cv::compare(mag, thr, ws.relief, cv::CMP_GT);
  out.mask = ws.relief;
  out.blank = false;
  return out;
}

// Thresholds one mode's image (dark, light or shaded discs) and keeps the
// elliptical blobs, in `det`. `relief` is used by the shaded mode only, as
// is `disc_per_spread` (Pattern).
void detect_mode(const Normalised& nz, const ReliefMask& relief, int pol,
                 const FiducialSearchOptions& o, double disc_per_spread, Detection& det) {
  if (pol == kShaded ? relief.blank : nz.blank) return;
  const int scale = det.scale;
  const int W = pol == kShaded ? relief.mask.cols : nz.n.cols;
  const int H = pol == kShaded ? relief.mask.rows : nz.n.rows;
  cv::Mat mask;
  if (pol == kDark) cv::threshold(nz.n8, mask, nz.otsu, 255, cv::THRESH_BINARY_INV);
  if (pol == kLight) cv::threshold(nz.n8, mask, nz.otsu, 255, cv::THRESH_BINARY);
  // Where Otsu cuts through noise (a capture with no inked marks, e.g. a
  // relief), the mask is salt and pepper, and thousands of ragged contours
  // would cost far more than the search: a 3x3 median clears them and
  // leaves any disc of more than ~2 px radius.
  if (pol != kShaded) cv::medianBlur(mask, mask, 3);
  if (pol == kShaded) {
    // Isolated specks (noise, what is left of side lobes) go first, or the
    // closing below would tie them to a disc as spurs: a pixel stays if at
    // least two of its 8 neighbours are set (thin rims keep theirs).
    Workspace& ws = workspace();
    cv::boxFilter(relief.mask, ws.count, CV_16U, cv::Size(3, 3), cv::Point(-1, -1), false,
                  cv::BORDER_CONSTANT);
    mask = ws.closed;
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
  }

  const double cos_tilt = std::cos(o.max_tilt_deg * kPi / 180);
  const double r_min = std::max(o.min_radius_px / scale, 2.0);  // detection-scale px
  const double r_max = 0.15 * std::min(W, H);
  std::vector<std::vector<cv::Point>> all;
  std::vector<cv::Vec4i> hierarchy;
  // Two levels (outlines and holes): every blob's outline is a top-level
  // contour, wherever it lies (e.g. on a card inside a darker surround), and
  // a ring's outline encloses its hole.
  cv::findContours(mask, all, hierarchy, cv::RETR_CCOMP, cv::CHAIN_APPROX_NONE);
  // Tests one outline (a contour, or for shaded discs the points of two)
  // and keeps it as a blob if it is elliptical enough.
  auto try_blob = [&](const std::vector<cv::Point>& c, int idx, int idx2) {
    std::vector<cv::Point> hull;
    cv::convexHull(c, hull);
    // A shaded disc's crescents may stay apart at one tip (a "C"): its
    // convex hull is the disc's outline. Elsewhere the outline itself is
    // tested, and must be nearly convex.
    std::vector<cv::Point> dense_hull;
    if (pol == kShaded) {
      for (size_t k = 0; k < hull.size(); ++k) {
        const cv::Point a = hull[k], e = hull[(k + 1) % hull.size()];
        const int steps = std::max(std::abs(e.x - a.x), std::abs(e.y - a.y));
        for (int t = 0; t < steps; ++t)
          dense_hull.push_back({a.x + (e.x - a.x) * t / steps, a.y + (e.y - a.y) * t / steps});
      }
      if (dense_hull.size() < 8) return false;
    }
    const auto& outline = pol == kShaded ? dense_hull : c;
    const cv::Moments mo = cv::moments(pol == kShaded ? hull : c);
    const double A = std::abs(mo.m00);
    // Contour vertices are boundary pixel centres, half a pixel inside the edge.
    const double r_eq = std::sqrt(A / kPi) + 0.5;
    if (r_eq < 0.8 * r_min || r_eq > r_max) return false;
    if (pol != kShaded && A < 0.85 * cv::contourArea(hull)) return false;
    const Vec2 cen{mo.m10 / mo.m00, mo.m01 / mo.m00};
    Sym2 C{mo.mu20 / mo.m00, mo.mu11 / mo.m00, mo.mu02 / mo.m00};
    const auto [l1, l2] = C.eig();
    if (!(l2 > 0)) return false;
    const double axis_ratio = std::sqrt(l2 / l1);
    if (axis_ratio < 0.75 * cos_tilt) return false;
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
  };
  // Small shaded outlines: maybe one crescent of a disc whose
  // other crescent the closing did not reach (a dim disc's crescents fade
  // over a wide angle). Their centres and sizes, for pairing below.
  struct Fragment {
    int idx;
    Vec2 center;
    double radius;
  };
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
    if (std::max(rect.width, rect.height) > 2 * r_max) continue;
    try_blob(c, idx, -1);
    // (One crescent alone can pass as a thick ellipse, off the disc's
    // centre: every small one is a fragment.)
    if (pol == kShaded && std::max(rect.width, rect.height) < r_max)
      fragments.push_back({idx, {rect.x + 0.5 * rect.width, rect.y + 0.5 * rect.height},
                           0.5 * std::max(rect.width, rect.height)});
  }
  // Pairs of fragments close enough to be the two crescents of one disc.
  if (fragments.size() <= 200) {
    std::vector<cv::Point> both;
    for (size_t i = 0; i < fragments.size(); ++i)
      for (size_t j = i + 1; j < fragments.size(); ++j) {
        const Fragment &f = fragments[i], &g = fragments[j];
        if (norm(f.center - g.center) > 1.2 * (f.radius + g.radius) + 2) continue;
        const auto &cf = det.contours[pol][f.idx], &cg = det.contours[pol][g.idx];
        both.assign(cf.begin(), cf.end());
        both.insert(both.end(), cg.begin(), cg.end());
        try_blob(both, f.idx, g.idx);
      }
  }
  auto& bl = det.blobs[pol];
  std::sort(bl.begin(), bl.end(),
            [](const Blob& x, const Blob& y) { return x.residual < y.residual; });
  if (bl.size() > static_cast<size_t>(o.max_candidates)) bl.resize(o.max_candidates);
}

// ---------------------------------------------------------------------------
// Sub-pixel area centroid at full resolution.

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

Refined refine_centroid(const cv::Mat& lum, const Blob& blob, const Detection& det, int pol) {
  const bool dark = pol == kDark;
  Refined out;
  const auto [l1, l2] = blob.cov.eig();
  const double semi_minor = 2 * std::sqrt(l2);
  // The window must hold the blur tails; the annulus outside it gives the
  // ground plane.
  double margin = std::clamp(0.4 * semi_minor + 2.0, 3.0, 15.0);
  double ring = std::clamp(0.3 * semi_minor, 2.0, 8.0);
  const Sym2 Ci = blob.cov.inverse();
  // Normalised radius squared: 1 on the blob's moment ellipse (a disc of
  // radius R has covariance R^2/4).
  auto rho2 = [&](Vec2 c, double x, double y) { return 0.25 * Ci.quad({x - c.x, y - c.y}); };
  // Keep window and annulus clear of other marks of the same polarity: their
  // tails would pull the centroid.
  {
    const double gap = clearance_px(blob, det, pol, margin + ring);
    if (gap < kInf) {
      margin = std::min(margin, 0.4 * gap);
      ring = std::min(ring, std::max(1.5, 0.3 * gap));
      if (margin < 1.5) return out;
    }
  }
  const double rho_w = 1 + margin / semi_minor, rho_o = 1 + (margin + ring) / semi_minor;
  const double rho_w2 = rho_w * rho_w, rho_o2 = rho_o * rho_o;
  // Half-extents of the ellipse {rho <= 1} are 2 sqrt(C_xx), 2 sqrt(C_yy).
  const double ex = 2 * std::sqrt(blob.cov.xx), ey = 2 * std::sqrt(blob.cov.yy);

  Vec2 c = blob.center;
  std::vector<std::array<double, 3>> ann;  // x - c, y - c, I
  std::vector<std::array<double, 4>> win;  // x, y, I, rho^2
  std::vector<float> tmp;
  // Ground plane g0 + gx (x - gc.x) + gy (y - gc.y), the ink deviation delta
  // and whether illumination scales them (see below).
  std::array<double, 3> g{};
  Vec2 gc{};
  double delta = 0;
  bool multiplicative = false;
  auto ground = [&](double x, double y) { return g[0] + g[1] * (x - gc.x) + g[2] * (y - gc.y); };
  for (int iter = 0; iter < 10; ++iter) {
    // The window must lie inside the image (a clipped disc has a wrong
    // centroid); the ground annulus may be clipped.
    if (c.x - rho_w * ex < 0 || c.y - rho_w * ey < 0 || c.x + rho_w * ex > lum.cols - 1 ||
        c.y + rho_w * ey > lum.rows - 1)
      return out;
    const int x0 = std::max(0, static_cast<int>(std::floor(c.x - rho_o * ex)));
    const int x1 = std::min(lum.cols - 1, static_cast<int>(std::ceil(c.x + rho_o * ex)));
    const int y0 = std::max(0, static_cast<int>(std::floor(c.y - rho_o * ey)));
    const int y1 = std::min(lum.rows - 1, static_cast<int>(std::ceil(c.y + rho_o * ey)));
    // Levels are estimated on the first two passes (the detection centre may
    // be off by a pixel); later passes only re-centre the window.
    const bool levels = iter < 2;
    ann.clear();
    win.clear();
    for (int y = y0; y <= y1; ++y) {
      const float* row = lum.ptr<float>(y);
      for (int x = x0; x <= x1; ++x) {
        const double r = rho2(c, x, y);
        if (r <= rho_w2)
          win.push_back({double(x), double(y), double(row[x]), r});
        else if (levels && r <= rho_o2)
          ann.push_back({x - c.x, y - c.y, double(row[x])});
      }
    }
    if (win.size() < 9) return out;
    if (levels) {
      if (ann.size() < 12) return out;
      // Ground plane by least squares, then once more without outliers
      // (3.5 robust sigmas): a smooth illumination gradient cancels.
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
        if (!cv::solve(Mm, cv::Vec3d(b[0], b[1], b[2]), sol, cv::DECOMP_CHOLESKY)) return out;
        g = {sol[0], sol[1], sol[2]};
        gc = c;
        tmp.clear();
        for (const auto& a : ann)
          tmp.push_back(static_cast<float>(std::abs(a[2] - (g[0] + g[1] * a[0] + g[2] * a[1]))));
        sigma = 1.4826 * percentile_of(tmp, 0.5);
        if (pass == 0)
          for (size_t i = 0; i < ann.size(); ++i)
            keep[i] = std::abs(ann[i][2] - (g[0] + g[1] * ann[i][0] + g[2] * ann[i][1])) <=
                      3.5 * sigma + 1e-30;
      }
      // Ink level: the disc's extreme (2nd percentile), so that clamping
      // only clips noise and blurred small discs stay linear.
      tmp.clear();
      for (const auto& p : win)
        if (p[3] <= 1.0) tmp.push_back(static_cast<float>(p[2] - ground(p[0], p[1])));
      if (tmp.size() < 5) return out;
      const double delta0 = percentile_of(tmp, dark ? 0.02 : 0.98);
      // Illumination scales ink and ground alike: where the ground is well
      // above zero, divide the disc's deviation by the ground's relative
      // level (exact for a multiplicative illumination field).
      multiplicative = g[0] > 0.25 * std::abs(delta0);
      delta = delta0;
      if (multiplicative) {
        tmp.clear();
        for (const auto& p : win)
          if (p[3] <= 1.0) {
            const double gr = ground(p[0], p[1]);
            if (!(gr > 0)) return out;
            tmp.push_back(static_cast<float>((p[2] - gr) * g[0] / gr));
          }
        delta = percentile_of(tmp, dark ? 0.02 : 0.98);
      }
      if ((dark ? -delta : delta) < std::max(5 * sigma, 1e-12 * std::abs(g[0]))) return out;
    }
    double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0, syy = 0;
    for (const auto& p : win) {
      const double gr = ground(p[0], p[1]);
      double u = p[2] - gr;
      if (multiplicative) {
        if (!(gr > 0)) return out;
        u *= g[0] / gr;
      }
      // Moments about the current centre (no cancellation far from 0).
      const double dx = p[0] - c.x, dy = p[1] - c.y;
      const double wgt = std::clamp(u / delta, 0.0, 1.0);
      sw += wgt;
      sx += wgt * dx;
      sy += wgt * dy;
      sxx += wgt * dx * dx;
      sxy += wgt * dx * dy;
      syy += wgt * dy * dy;
    }
    if (!(sw > 0)) return out;
    const Vec2 d1{sx / sw, sy / sw};
    const Vec2 cn = c + d1;
    out.cov = {sxx / sw - d1.x * d1.x, sxy / sw - d1.x * d1.y, syy / sw - d1.y * d1.y};
    if (norm(cn - blob.center) > 0.5 * semi_minor + 1) return out;  // wandered off
    const double step = norm(d1);
    c = cn;
    out.area = sw;
    out.contrast = delta;
    if (step < 1e-4 && !levels) break;
  }
  out.ok = true;
  out.centroid = c;
  out.ground = ground(c.x, c.y);
  out.g = g;
  out.gc = gc;
  out.multiplicative = multiplicative;
  return out;
}

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
  const auto [l1, l2] = blob.cov.eig();
  const double a_out = 2 * std::sqrt(l1), b_out = 2 * std::sqrt(l2);  // outline semi-axes
  if (!(b_out >= 2.5)) return out;
  const Sym2 Ci = blob.cov.inverse();
  const Sym2 S_out{0.25 * Ci.xx, 0.25 * Ci.xy, 0.25 * Ci.yy};  // x^T S x = 1 on the outline
  const Vec2 c0 = blob.center;
  double margin = std::clamp(0.5 * b_out, 4.0, 12.0);
  {
    const double gap = clearance_px(blob, det, kShaded, margin);
    if (gap < kInf) margin = std::min(margin, 0.8 * gap);
    if (margin < 2.5) return out;
  }
  // The outline is the rim's outer edge at the detection threshold (closed,
  // hull); the rim's middle lies ~2 px inside it, its inner edge up to ~6 px.
  const double rho_o = 1 + margin / b_out;
  const double band_in = 1 - std::min(7.0, 0.6 * b_out) / b_out, band_out = 1 + 1.5 / b_out;
  const double ex = rho_o * 2 * std::sqrt(blob.cov.xx), ey = rho_o * 2 * std::sqrt(blob.cov.yy);
  if (c0.x - ex < 1 || c0.y - ey < 1 || c0.x + ex > lum.cols - 2 || c0.y + ey > lum.rows - 2)
    return out;  // clipped by the frame

  // Ground: quadratic (plane if the flat top is too small to pin the
  // curvature) in coordinates scaled by the outline's size.
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
        const double r = std::sqrt(S_out.quad({x - c0.x, y - c0.y}));
        if (r > rho_o || (r > band_in && r < band_out)) continue;
        inner += r <= band_in;
        gpx.push_back({d.x, d.y, double(row[x])});
      }
    }
  }
  const int nf = inner >= 20 ? 6 : 3;
  if (static_cast<int>(gpx.size()) < 4 * nf + 8) return out;
  std::array<double, 6> gc{};
  double g_sigma = 0;
  {
    // Least squares, then again without the outliers (3.5 robust sigmas:
    // what is left of the rim, other marks).
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
      if (!cv::solve(Mm, cv::Vec6d(b), sol, cv::DECOMP_CHOLESKY)) return out;
      for (int r = 0; r < 6; ++r) gc[r] = sol[r];
      res.clear();
      for (size_t i = 0; i < gpx.size(); ++i) {
        const Px& p = gpx[i];
        e[i] = p.v - (gc[0] + gc[1] * p.x + gc[2] * p.y + gc[3] * p.x * p.x +
                      gc[4] * p.x * p.y + gc[5] * p.y * p.y);
        if (keep[i]) res.push_back(static_cast<float>(std::abs(e[i])));
      }
      g_sigma = 1.4826 * percentile_of(res, 0.5);
      for (size_t i = 0; i < gpx.size(); ++i) keep[i] = std::abs(e[i]) <= 3.5 * g_sigma + 1e-30;
    }
  }
  auto ground = [&](double x, double y) {
    const double u = (x - c0.x) / a_out, v = (y - c0.y) / a_out;
    return gc[0] + gc[1] * u + gc[2] * v + gc[3] * u * u + gc[4] * u * v + gc[5] * v * v;
  };
  const double g0 = gc[0];
  // Illumination scales rim and ground alike where the ground is well above
  // zero (see refine_centroid).
  bool multiplicative = g0 > 0;
  for (double sx : {-1.0, 1.0})
    for (double sy : {-1.0, 1.0})
      multiplicative = multiplicative && ground(c0.x + sx * ex, c0.y + sy * ey) > 0.2 * g0;
  // The normalised deviation from the ground on the pixel grid, once, over
  // the window and a few pixels more (rays may reach a little past it).
  const int px0 = std::max(0, static_cast<int>(std::floor(c0.x - ex)) - 6);
  const int py0 = std::max(0, static_cast<int>(std::floor(c0.y - ey)) - 6);
  const int px1 = std::min(lum.cols - 1, static_cast<int>(std::ceil(c0.x + ex)) + 6);
  const int py1 = std::min(lum.rows - 1, static_cast<int>(std::ceil(c0.y + ey)) + 6);
  cv::Mat dev_patch(py1 - py0 + 1, px1 - px0 + 1, CV_32F);
  for (int y = py0; y <= py1; ++y) {
    const float* row = lum.ptr<float>(y);
    float* out_row = dev_patch.ptr<float>(y - py0);
    for (int x = px0; x <= px1; ++x) {
      const double g = ground(x, y);
      const double u = row[x] - g;
      out_row[x - px0] = static_cast<float>(multiplicative ? u * g0 / std::max(g, 0.05 * g0) : u);
    }
  }
  // NaN outside the patch.
  auto deviation = [&](double x, double y) {
    x -= px0;
    y -= py0;
    if (!(x >= 0 && y >= 0 && x <= dev_patch.cols - 1 && y <= dev_patch.rows - 1))
      return std::numeric_limits<double>::quiet_NaN();
    return bilinear(dev_patch, x, y);
  };
  // Soft threshold: noise alone adds weight everywhere in the ray's window,
  // which would pull each rim point toward the window's middle.
  const double t = 2 * g_sigma;

  // Where the rim is: the peak of the mean |deviation| over ellipses
  // concentric with the outline. The outline is only roughly the rim's
  // outer edge (a strong rim's tails pass the detection threshold farther
  // out, a closing may add a bridge), so this, not the outline, starts the
  // fit.
  double shrink = 1;
  {
    constexpr int kBins = 48;
    std::array<double, kBins> acc{}, cnt{};
    const int x0 = static_cast<int>(std::floor(c0.x - ex)), x1 = static_cast<int>(std::ceil(c0.x + ex));
    const int y0 = static_cast<int>(std::floor(c0.y - ey)), y1 = static_cast<int>(std::ceil(c0.y + ey));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const double r = std::sqrt(S_out.quad({x - c0.x, y - c0.y}));
        if (r >= rho_o) continue;
        const int k = static_cast<int>(r / rho_o * kBins);
        acc[k] += std::abs(deviation(x, y));
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
    if (kp < 0) return out;
    double sw = 0, swr = 0;
    for (int k = std::max(0, kp - 2); k <= std::min(kBins - 1, kp + 2); ++k) {
      if (cnt[k] < 1) continue;
      const double m = acc[k] / cnt[k];
      sw += m;
      swr += m * (k + 0.5) * rho_o / kBins;
    }
    shrink = swr / sw;
  }

  Vec2 c = c0;
  Sym2 S{S_out.xx / (shrink * shrink), S_out.xy / (shrink * shrink), S_out.yy / (shrink * shrink)};
  double hw = std::clamp(0.35 * b_out, 2.0, 5.0);  // half-width of each ray's window, px
  const int n_rays = std::clamp(static_cast<int>(2 * kPi * std::sqrt(a_out * b_out) / 1.5), 24, 256);
  constexpr double kStep = 0.5;  // px along each ray
  bool converged = false;
  double last_step = kInf;
  std::vector<float> peaks;
  for (int iter = 0; iter < 12 && !converged; ++iter) {
    // M maps the unit circle onto the current ellipse.
    const Sym2 M = S.inv_sqrt();
    const double scale = std::sqrt(std::sqrt(1 / S.det()));  // sqrt(a b), for conditioning
    double N[5][5] = {}, rhs[5] = {};
    double spread = 0, total = 0, sum_abs = 0, w_max = 0;
    Vec2 dip{};
    int rays_on = 0;
    std::vector<double> ray_w(n_rays, 0);
    peaks.clear();
    for (int k = 0; k < n_rays; ++k) {
      const double th = 2 * kPi * k / n_rays;
      const Vec2 p = M.mul({std::cos(th), std::sin(th)});
      const double rk = norm(p);
      const Vec2 e = (1 / rk) * p;
      const double h = std::min(hw, 0.6 * rk);
      double sw = 0, swd = 0, swdd = 0, peak = 0;
      for (double d = -h; d <= h + 1e-9; d += kStep) {
        const Vec2 q = c + (rk + d) * e;
        const double u = deviation(q.x, q.y);
        if (std::isnan(u)) return out;  // the ellipse grew past the window
        const double w = std::max(std::abs(u) - t, 0.0);
        sw += w;
        swd += w * d;
        swdd += w * d * d;
        peak = std::max(peak, std::abs(u));
        sum_abs += std::abs(u);
        dip = dip + u * ((rk + d) * e);
      }
      peaks.push_back(static_cast<float>(peak));
      if (!(sw > 0)) continue;
      const double dm = swd / sw;
      spread += swdd - sw * dm * dm;
      total += sw;
      ray_w[k] = sw;
      w_max = std::max(w_max, sw);
      const Vec2 x = (1 / scale) * ((rk + dm) * e);
      const double f[5] = {x.x * x.x, x.x * x.y, x.y * x.y, x.x, x.y};
      for (int r = 0; r < 5; ++r) {
        rhs[r] += sw * f[r];
        for (int q = 0; q < 5; ++q) N[r][q] += sw * f[r] * f[q];
      }
    }
    // The outline must be there on most of its way round (crescents fade
    // only near the two points where the edge runs along the light).
    for (double w : ray_w) rays_on += w > 0.1 * w_max;
    if (!(w_max > 0) || rays_on < 0.4 * n_rays) return out;
    cv::Matx<double, 5, 5> Nm;
    cv::Vec<double, 5> bm, sol;
    for (int r = 0; r < 5; ++r) {
      bm[r] = rhs[r];
      for (int q = 0; q < 5; ++q) Nm(r, q) = N[r][q];
    }
    if (!cv::solve(Nm, bm, sol, cv::DECOMP_SVD)) return out;
    const double A = sol[0], B = sol[1], C = sol[2], D = sol[3], E = sol[4];
    const double det2 = 4 * A * C - B * B;
    if (!(A > 0 && C > 0 && det2 > 0)) return out;
    const Vec2 x0{(-2 * C * D + B * E) / det2, (B * D - 2 * A * E) / det2};
    const double F0 = A * x0.x * x0.x + B * x0.x * x0.y + C * x0.y * x0.y + D * x0.x + E * x0.y - 1;
    if (!(F0 < 0)) return out;
    const double k2 = -F0 * scale * scale;
    const Sym2 S_new{A / k2, 0.5 * B / k2, C / k2};
    const Vec2 step = scale * x0;
    // The rim's ellipse stays near the outline's.
    const auto [s1, s2] = S_new.eig();
    if (!(s2 > 0) || 1 / std::sqrt(s2) > 1.5 * a_out || 1 / std::sqrt(s1) < 0.3 * b_out) return out;
    c = c + step;
    S = S_new;
    if (norm(c - c0) > 0.5 * b_out + 1) return out;  // wandered off
    const double sd = std::sqrt(std::max(spread, 0.0) / total);
    hw = std::clamp(2 * sd + 1, 2.0, std::max(2.0, 0.5 / std::sqrt(s1)));
    converged = iter >= 2 && norm(step) < 1e-3;
    last_step = norm(step);
    out.dipole = (1 / std::max(sum_abs, 1e-300)) * dip;
  }
  if (last_step > 0.01) return out;  // still moving: no stable rim
  out.ok = true;
  out.centroid = c;
  const Sym2 Sinv = S.inverse();
  out.cov = {0.25 * Sinv.xx, 0.25 * Sinv.xy, 0.25 * Sinv.yy};
  out.area = kPi / std::sqrt(S.det());
  out.contrast = percentile_of(peaks, 0.9);
  out.ground = g0;
  return out;
}

// ---------------------------------------------------------------------------
// Identification: which blobs are which layout disc.

struct Verdict {
  bool ok = false;
  double score = kInf;
  H3 H{};
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

// Refined::opposite above which a blob looks like one crescent of a relief.
constexpr double kBipolarOpposite = 0.3;

uint64_t key_of(const std::array<int, 5>& cand) {
  uint64_t k = 0;
  for (int c : cand) k = (k << 12) | static_cast<uint64_t>(c + 1);
  return k;
}

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
  const Refined* get(int b) {
    if (!done_[b]) {
      r_[b] = pol_ == kShaded ? refine_relief(lum_, det_.blobs[pol_][b], det_)
                              : refine_centroid(lum_, det_.blobs[pol_][b], det_, pol_);
      done_[b] = 1;
    }
    return r_[b].ok ? &r_[b] : nullptr;
  }
  // Refined::opposite of a refined printed disc or ring (0 when shaded).
  double opposite(int b) {
    Refined& R = r_[b];
    if (R.opposite < 0)
      R.opposite =
          pol_ == kShaded ? 0 : opposite_deviation(lum_, det_.blobs[pol_][b], R, pol_ == kDark);
    return R.opposite;
  }
  const cv::Mat& image() const { return lum_; }

 private:
  const cv::Mat& lum_;
  const Detection& det_;
  int pol_;
  std::vector<char> done_;
  std::vector<Refined> r_;
};

class Identifier {
 public:
  Identifier(const std::vector<Blob>& blobs, const Pattern& pat, const FiducialSearchOptions& o,
             RefinedCache& refined, bool shaded)
      : blobs_(blobs),
        pat_(pat),
        o_(o),
        refined_(refined),
        shaded_(shaded),
        cos_tilt_(std::cos(o.max_tilt_deg * kPi / 180)) {}

  // Complete patterns, seeded by collinear triples: perspective cannot break
  // collinearity, so this holds at any tilt.
  Verdict search_complete() {
    Verdict best;
    const int N = static_cast<int>(blobs_.size());
    for (int i = 0; i < N; ++i)
      for (int j = i + 1; j < N; ++j) {
        if (!area_ok(i, j) || !spacing_ok(i, j, pat_.a, pat_.b)) continue;
        const Vec2 ci = blobs_[i].center, cj = blobs_[j].center;
        const double D = norm(cj - ci);
        for (int m = 0; m < N; ++m) {
          if (m == i || m == j || !area_ok(m, i) || !area_ok(m, j)) continue;
          const Vec2 v = blobs_[m].center - ci;
          const double t = dot(v, cj - ci) / (D * D);
          if (t < 0.05 || t > 0.95) continue;
          if (std::abs(cross(cj - ci, v)) / D > 0.04 * D + 2.0) continue;
          for (int orient = 0; orient < 2; ++orient)
            extend_triple(orient ? j : i, m, orient ? i : j, best);
        }
      }
    return best;
  }

  // Partial patterns, seeded by pairs under a whitened similarity: the mean
  // disc ellipse undoes the tilt to first order. Returns every acceptable
  // hypothesis with >= 4 discs; 3-disc ones only count for max_seen().
  std::vector<Verdict> search_partial() {
    std::vector<Verdict> out;
    const int N = static_cast<int>(blobs_.size());
    std::vector<Vec2> w(N);
    for (int i = 0; i < N; ++i)
      for (int j = i + 1; j < N; ++j) {
        if (!area_ok(i, j)) continue;
        const Sym2 Cm{0.5 * (blobs_[i].cov.xx + blobs_[j].cov.xx),
                      0.5 * (blobs_[i].cov.xy + blobs_[j].cov.xy),
                      0.5 * (blobs_[i].cov.yy + blobs_[j].cov.yy)};
        const Sym2 W = Cm.inv_sqrt();
        for (int k = 0; k < N; ++k) w[k] = W.mul(blobs_[k].center);
        const double dw = norm(w[j] - w[i]);
        for (int u = 0; u < 5; ++u)
          for (int v = 0; v < 5; ++v) {
            if (u == v) continue;
            // A disc of radius r has covariance r^2/4: whitened, its radius is 2.
            const double expected = 2.0 * norm(pat_.p[v] - pat_.p[u]) / pat_.r_mm;
            if (dw < 0.6 * expected || dw > 1.6 * expected) continue;
            for (int refl = 0; refl < 2; ++refl) grow_pair(i, j, u, v, refl == 1, w, out);
          }
      }
    return out;
  }

  // Most discs in any partial hypothesis that fit the pattern (for the
  // message when nothing was identified).
  int max_seen() const { return max_seen_; }

 private:
  bool area_ok(int i, int j) const {
    const double r = blobs_[i].area / blobs_[j].area;
    return r <= o_.max_area_ratio && r >= 1 / o_.max_area_ratio;
  }

  // Is the distance between blobs i and j, measured in the metric of their
  // own ellipses (which undoes the tilt), the distance between layout discs
  // u and v? A disc of radius r has covariance r^2/4, so in whitened units
  // its radius is 2. Perspective, blur and thresholds leave a factor ~1.6;
  // shaded outlines are rougher.
  bool spacing_ok(int i, int j, int u, int v) const {
    const Sym2& Ci = blobs_[i].cov;
    const Sym2& Cj = blobs_[j].cov;
    const Sym2 Cm{0.5 * (Ci.xx + Cj.xx), 0.5 * (Ci.xy + Cj.xy), 0.5 * (Ci.yy + Cj.yy)};
    const double dw = std::sqrt(Cm.inverse().quad(blobs_[j].center - blobs_[i].center));
    const double expected = 2.0 * norm(pat_.p[v] - pat_.p[u]) / pat_.r_mm;
    const double slack = shaded_ ? 2.2 : 1.6;
    return dw > expected / slack && dw < expected * slack;
  }

  // Similarity (complex) z = alpha * q + beta with q the (optionally
  // reflected) layout point.
  static std::pair<Vec2, Vec2> similarity(Vec2 q0, Vec2 q1, Vec2 z0, Vec2 z1) {
    const Vec2 dq = q1 - q0, dz = z1 - z0;
    const double den = dot(dq, dq);
    const Vec2 alpha{(dz.x * dq.x + dz.y * dq.y) / den, (dz.y * dq.x - dz.x * dq.y) / den};
    const Vec2 beta{z0.x - (alpha.x * q0.x - alpha.y * q0.y),
                    z0.y - (alpha.x * q0.y + alpha.y * q0.x)};
    return {alpha, beta};
  }
  static Vec2 sim_apply(const std::pair<Vec2, Vec2>& s, Vec2 q) {
    return {s.first.x * q.x - s.first.y * q.y + s.second.x,
            s.first.x * q.y + s.first.y * q.x + s.second.y};
  }

  void extend_triple(int A, int M, int B, Verdict& best) {
    const int N = static_cast<int>(blobs_.size());
    const Vec2 cA = blobs_[A].center, cB = blobs_[B].center;
    const double span = norm(cB - cA);
    // Where C can be, from the layout's distances alone: tilt shortens a
    // length by at most cos(tilt) relative to another; perspective adds some.
    const Vec2 ab = pat_.p[pat_.b] - pat_.p[pat_.a], ac = pat_.p[pat_.c] - pat_.p[pat_.a];
    const double r_ac = norm(ac) / pat_.ab_mm;
    const double off_ac = std::abs(cross(ab, ac)) / (pat_.ab_mm * pat_.ab_mm);
    for (int C = 0; C < N; ++C) {
      if (C == A || C == M || C == B || !area_ok(C, A) || !area_ok(C, B)) continue;
      const Vec2 v = blobs_[C].center - cA;
      const double r = norm(v) / span;
      if (r < 0.6 * cos_tilt_ * r_ac || r > 1.7 * r_ac / cos_tilt_) continue;
      if (std::abs(cross(cB - cA, v)) / (span * span) < 0.5 * cos_tilt_ * off_ac) continue;
      if (!spacing_ok(A, C, pat_.a, pat_.c) || !spacing_ok(B, C, pat_.b, pat_.c)) continue;
      const auto Aff =
          fit_affine({pat_.p[pat_.a], pat_.p[pat_.b], pat_.p[pat_.c]}, {cA, cB, blobs_[C].center});
      if (!Aff) continue;
      const Vec2 dpred = map_point(*Aff, pat_.p[pat_.d]);
      for (int D = 0; D < N; ++D) {
        if (D == A || D == M || D == B || D == C || !area_ok(D, A) || !area_ok(D, B) ||
            !area_ok(D, C))
          continue;
        if (norm(blobs_[D].center - dpred) > 0.5 * span) continue;
        if (!spacing_ok(A, D, pat_.a, pat_.d) || !spacing_ok(C, D, pat_.c, pat_.d)) continue;
        std::array<int, 5> cand{};
        cand[pat_.a] = A;
        cand[pat_.m] = M;
        cand[pat_.b] = B;
        cand[pat_.c] = C;
        cand[pat_.d] = D;
        const Verdict vd = verify(cand);
        if (vd.ok && vd.score < best.score) best = vd;
      }
    }
  }

  void grow_pair(int i, int j, int u, int v, bool refl, const std::vector<Vec2>& w,
                 std::vector<Verdict>& out) {
    const int N = static_cast<int>(blobs_.size());
    auto q = [&](int k) { return Vec2{pat_.p[k].x, refl ? -pat_.p[k].y : pat_.p[k].y}; };
    const auto S = similarity(q(u), q(v), w[i], w[j]);
    const double tol = 0.15 * std::hypot(S.first.x, S.first.y) * pat_.ab_mm;
    std::array<int, 5> cand{-1, -1, -1, -1, -1};
    cand[u] = i;
    cand[v] = j;
    auto used = [&](int b) { return std::find(cand.begin(), cand.end(), b) != cand.end(); };
    for (int k = 0; k < 5; ++k) {
      if (cand[k] >= 0) continue;
      const Vec2 z = sim_apply(S, q(k));
      int bestb = -1;
      double bestd = tol * tol;
      for (int b = 0; b < N; ++b) {
        const Vec2 e = w[b] - z;
        const double d = dot(e, e);
        if (d >= bestd || used(b) || !area_ok(b, i) || !area_ok(b, j)) continue;
        bestd = d;
        bestb = b;
      }
      // A blob that cannot be measured (at the border, touching other ink)
      // counts as missing.
      if (bestb >= 0 && !refined_.get(bestb)) bestb = -1;
      cand[k] = bestb;
    }
    const int n =
        static_cast<int>(std::count_if(cand.begin(), cand.end(), [](int c) { return c >= 0; }));
    if (n < 3) return;
    if (!seen_.insert(key_of(cand)).second) return;
    if (n == 3) {
      const Verdict v3 = verify3(cand);
      if (v3.ok || v3.seen) max_seen_ = std::max(max_seen_, 3);
      return;
    }
    const Verdict vd = verify(cand);
    if (vd.ok) out.push_back(vd);
    if (vd.ok || vd.seen) max_seen_ = std::max(max_seen_, vd.n);
  }

  // Every matched disc's measured image must be the disc the map predicts
  // there: second moments P = (r^2/4) J J^T plus an isotropic blur s^2 (the
  // same for all discs, fitted), and area pi r^2 |det J| (blur-invariant).
  // Returns the mean squared normalised deviation, or nullopt if any disc is
  // out of tolerance.
  // Eigenvalues of Q^-1 C, largest first (nullopt if not positive).
  static std::optional<std::pair<double, double>> relative_eig(const Sym2& Q, const Sym2& C) {
    const Sym2 Qi = Q.inverse();
    const double tr = Qi.xx * C.xx + 2 * Qi.xy * C.xy + Qi.yy * C.yy;
    const double det = C.det() / Q.det();
    const double disc = std::sqrt(std::max(0.0, 0.25 * tr * tr - det));
    const double mu1 = 0.5 * tr + disc, mu2 = 0.5 * tr - disc;
    if (!(mu2 > 0)) return std::nullopt;
    return std::pair{mu1, mu2};
  }

  // Relief discs (shaded mode): refine_relief() measured each disc's image
  // ellipse, which must be the projected disc P the map predicts, in size
  // and shape, to within the tolerances of printed discs. Under one light
  // every disc shows its light crescent on the same side, so the dipoles
  // share a direction (perspective turns them a little) and are a good
  // fraction of the disc's radius; rings (a diffuse light) have none at all.
  // Texture has them in all directions.
  std::optional<double> relief_shape_score(const std::array<Sym2, 5>& P,
                                           const std::array<int, 5>& cand, bool strict) const {
    const double lens = strict ? 0.0 : 3 * o_.max_fit_error_frac;
    const double tol_shape = std::log(strict ? 1.25 : 1.4) + lens;
    Vec2 sum_dir{};
    int n = 0, rings = 0;
    for (int k = 0; k < 5; ++k) {
      if (cand[k] < 0) continue;
      ++n;
      const Vec2 d = refined_.get(cand[k])->dipole;
      const double r_px = 2 * std::sqrt(std::sqrt(P[k].det()));  // sqrt(a b), semi-axes a, b
      if (norm(d) < 0.15 * r_px) {
        ++rings;
        continue;
      }
      sum_dir = sum_dir + (1 / norm(d)) * d;
    }
    if (rings > 0 && rings < n) return std::nullopt;
    if (rings == 0) {
      if (norm(sum_dir) < 1e-12) return std::nullopt;
      const Vec2 mean_dir = (1 / norm(sum_dir)) * sum_dir;
      for (int k = 0; k < 5; ++k) {
        if (cand[k] < 0) continue;
        const Vec2 d = refined_.get(cand[k])->dipole;
        if (dot(d, mean_dir) < std::cos(35 * kPi / 180) * norm(d)) return std::nullopt;
      }
    }
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
  std::optional<double> shape_score(const H3& H, const std::array<int, 5>& cand, bool strict,
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
      const Mat2 J = jacobian(H, pat_.p[k]);
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
      // fill short of a crisp disc's, give it the ring test below. Four
      // discs must pass as printed discs.
      if (strict || fill / n > 0.85) return std::nullopt;
      sum = 0;
    }
    // Rings: only the outlines (filled) are comparable. Their size relative
    // to the disc depends on the threshold and the ring's width, so one
    // common factor kappa is fitted; each outline must then match
    // kappa * P, to within the tolerance plus a detection pixel.
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
  bool patch_ok(const H3& H, const std::array<int, 5>& cand) const {
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

  bool in_front(const H3& H) const {
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

  Verdict verify(const std::array<int, 5>& cand) {
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
    if (v.n == 5) {
      // First with the blobs' outline centres, a pixel or two off (more for
      // shaded outlines), so that hopeless hypotheses cost no refinement.
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
        if (std::sqrt(ss / 5) > std::max(1.0, o_.max_fit_error_frac * span) + slack) return v;
      }
    }
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
    std::vector<H3> maps;
    if (v.n == 4 && (missing == pat_.c || missing == pat_.d)) {
      // Four discs that include the collinear triple fix only a
      // one-parameter family of homographies (the null space of the DLT is
      // two-dimensional); the discs' images (areas, shapes) pick the member.
      const auto sol = dlt(src, dst);
      if (!sol) return v;
      for (int i = 0; i < 180; ++i) {
        const double th = kPi * i / 180, c = std::cos(th), s = std::sin(th);
        H3 H;
        for (int k = 0; k < 9; ++k) H[k] = c * sol->H[0][k] + s * sol->H[1][k];
        maps.push_back(H);
      }
    } else {
      const auto H = fit_homography(src, dst);
      if (!H) return v;
      maps.push_back(*H);
    }
    for (H3& H : maps) {
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
  Verdict verify3(const std::array<int, 5>& cand) {
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

  const std::vector<Blob>& blobs_;
  const Pattern& pat_;
  const FiducialSearchOptions& o_;
  RefinedCache& refined_;
  bool shaded_;  // relief discs: outlines are rough, the rim fit is what counts
  double cos_tilt_;
  std::set<uint64_t> seen_;
  int max_seen_ = 0;  // most discs of any hypothesis that fit the pattern
};

struct Identification {
  Verdict verdict;        // ok when identified (n = 4 or 5)
  int partial_count = 0;  // discs seen in the best unidentified partial pattern
  bool ambiguous = false;
};

Identification identify(const std::vector<Blob>& blobs, const Pattern& pat,
                        const FiducialSearchOptions& o, RefinedCache& refined, bool shaded) {
  Identification id;
  if (blobs.size() < 3) return id;
  Identifier ider(blobs, pat, o, refined, shaded);
  if (blobs.size() >= 5) {
    id.verdict = ider.search_complete();
    if (id.verdict.ok) return id;
  }
  std::vector<Verdict> partial = ider.search_partial();
  id.partial_count = ider.max_seen();
  if (partial.empty()) return id;
  std::sort(partial.begin(), partial.end(), [](const Verdict& x, const Verdict& y) {
    return x.n != y.n ? x.n > y.n : x.score < y.score;
  });
  const Verdict& best = partial.front();
  if (best.n == 5) {
    id.verdict = best;
    return id;
  }
  // Shaded outlines say too little about each disc to trust four, nor do
  // four crescents taken for printed discs.
  if (shaded || best.bipolar) {
    id.partial_count = 4;
    return id;
  }
  // Four discs: accept only if every acceptable hypothesis names the same
  // discs the same way (e.g. with T3 hidden and no reference patch to look
  // at, the four corners fit under each symmetry of the rectangle).
  id.partial_count = 4;
  for (const Verdict& v : partial)
    if (v.cand != best.cand) {
      id.ambiguous = true;
      return id;
    }
  id.verdict = best;
  return id;
}

bool all_finite(const cv::Mat& m) {
  // An all-ones exponent marks Inf and NaN. This branch-free integer scan
  // vectorises; cv::checkRange takes ~1 ms on a 1280x720 image.
  for (int y = 0; y < m.rows; ++y) {
    const uint32_t* row = m.ptr<uint32_t>(y);
    uint32_t bad = 0;
    for (int x = 0; x < m.cols; ++x)
      bad |= static_cast<uint32_t>((row[x] & 0x7f800000u) == 0x7f800000u);
    if (bad) return false;
  }
  return true;
}

std::string missing_names(const Pattern& pat, const std::array<int, 5>& cand) {
  std::string s;
  for (int k = 0; k < 5; ++k)
    if (cand[k] < 0) s += (s.empty() ? "" : ", ") + pat.id[k];
  return s;
}

}  // namespace

FiducialSearchResult find_fiducials(const cv::Mat& luminance, const TargetLayout& layout,
                                    const FiducialSearchOptions& options) {
  options.validate();
  if (luminance.empty() || luminance.type() != CV_32FC1)
    throw std::invalid_argument(
        "find_fiducials needs a non-empty single-channel float (CV_32FC1) luminance image");
  if (!all_finite(luminance))
    throw std::invalid_argument(
        "find_fiducials got non-finite pixels: apply the loader's non-finite policy first");
  const Pattern pat = make_pattern(layout);
  // The coarse pass's buffers (a quarter of the pixels; the padded mask of
  // detect_mode a little more) stay for the next call; larger ones go.
  struct TrimWorkspace {
    size_t keep;
    ~TrimWorkspace() { workspace().trim(keep); }
  } trim{std::max<size_t>(luminance.total() * 3 / 10, size_t{1} << 18)};

  std::vector<int> scales;
  // Coarse first (fast): a 2x-downsampled copy keeps discs of >= 5 px radius
  // detectable. Full resolution only if the coarse pass finds no full set.
  if (std::min(luminance.cols, luminance.rows) >= 400) scales.push_back(2);
  if (scales.empty() || !options.coarse_only) scales.push_back(1);
  const bool layout_dark = layout.polarity == Polarity::dark_bars_on_light;
  // The layout's polarity first; shaded (a relief through a gel: crescents
  // or rings) last, as it is the least selective.
  const std::array<int, 3> pol_order = layout_dark ? std::array<int, 3>{kDark, kLight, kShaded}
                                                   : std::array<int, 3>{kLight, kDark, kShaded};

  FiducialSearchResult best;
  int best_partial = 0;
  bool any_ambiguous = false;
  double best_score = kInf;
  int best_pol = -1;
  // The best answer's discs are crescents taken for printed discs or rings
  // (Verdict::bipolar): every other mode, at every scale, may still replace
  // it.
  bool best_bipolar = false;
  // Scale by scale, every mode on the coarse copy first: whichever way the
  // discs show, they are usually found there in a few ms, and the costly
  // full-resolution passes run only for small discs or none found.
  for (size_t si = 0; si < scales.size(); ++si) {
    const int scale = scales[si];
    cv::Mat img;
    if (scale == 1) {
      img = luminance;
    } else {
      cv::resize(luminance, workspace().img,
                 cv::Size(luminance.cols / scale, luminance.rows / scale), 0, 0, cv::INTER_AREA);
      img = workspace().img;
    }
    std::optional<Normalised> nz;
    std::optional<ReliefMask> relief;
    Detection det;
    det.scale = scale;
    for (int pol : pol_order) {
      // Four discs found in one mode: only that mode may show the fifth
      // (e.g. at full resolution).
      if (best.found && !best_bipolar && pol != best_pol) continue;
      if (pol == kShaded) {
        if (!relief) relief = relief_mask(img);
      } else if (!nz) {
        nz = normalise(img);
      }
      static const Normalised kNone;
      static const ReliefMask kNoRelief;
      detect_mode(nz ? *nz : kNone, relief ? *relief : kNoRelief, pol, options,
                  pat.disc_per_spread, det);
      const auto& blobs = det.blobs[pol];
      RefinedCache refined(luminance, det, pol);
      const Identification id = identify(blobs, pat, options, refined, pol == kShaded);
      best_partial = std::max(best_partial, id.partial_count);
      any_ambiguous = any_ambiguous || id.ambiguous;
      const Verdict& v = id.verdict;
      if (!v.ok) continue;
      const int n = v.n;
      // Prefer discs that are no relief's crescents (the shaded mode's are
      // fitted to both crescents), then more discs, then the better fit.
      if (best.found) {
        if (v.bipolar && !best_bipolar) continue;
        if (v.bipolar == best_bipolar &&
            (n < static_cast<int>(best.discs.size()) ||
             (n == static_cast<int>(best.discs.size()) && v.score >= best_score)))
          continue;
      }
      FiducialSearchResult r;
      r.found = true;
      r.dark_on_light = pol == kDark;
      r.shaded = pol == kShaded;
      r.candidates = static_cast<int>(blobs.size());
      r.image_from_target = v.H;
      r.fit_rms_px = v.rms_px;
      for (int k = 0; k < 5; ++k) {
        const int b = v.cand[k];
        if (b < 0) continue;
        const Refined* f = refined.get(b);  // verified, so refined
        r.discs.push_back(
            {pat.id[k], f->centroid, f->area, blobs[b].axis_ratio, blobs[b].residual, f->contrast});
      }
      if (n == 4)
        r.warning = fmt::format(
            "only 4 of the 5 fiducial discs were found ({} is hidden, out of view or unusable): "
            "the pose rests on 4 discs; frame the whole target for a better fit",
            missing_names(pat, v.cand));
      best = std::move(r);
      best_score = v.score;
      best_pol = pol;
      best_bipolar = v.bipolar;
      if (n == 5 && !best_bipolar) return best;
    }
    if (best.found && !best_bipolar) {
      // The missing disc's area is within max_area_ratio of the found ones';
      // if even the smallest such disc would have been seen at this scale, a
      // finer one will not find it either.
      double r_min_found = kInf;
      for (const auto& d : best.discs)
        r_min_found = std::min(r_min_found, std::sqrt(d.area_px / kPi));
      const double r_detectable = std::max(options.min_radius_px, 2.5 * scale);
      if (r_min_found / std::sqrt(options.max_area_ratio) >= r_detectable) return best;
    }
  }
  if (best.found && !best_bipolar) return best;
  if (best.found) {
    // Five crescents of a relief fit the pattern as filled discs, but no
    // mode fitted the discs themselves: their centroids would be up to a
    // radius off, and the pose with them. Refused rather than reported.
    FiducialSearchResult r;
    r.dark_on_light = layout_dark;
    r.problem =
        "the fiducial discs show as a relief's light and dark crescents, too small or blurred to fit "
        "their rims (only the crescents themselves were found, up to a disc radius off the discs' "
        "centres): capture the target larger or sharper";
    return r;
  }
  best = {};
  best.dark_on_light = layout_dark;
  if (best_partial >= 5)
    best.problem =
        "five discs match the fiducial pattern, but the rest of the capture does not match layout.json "
        "(the reference patch is not where the layout puts it): measure with the layout of the captured "
        "target";
  else if (best_partial >= 3 || any_ambiguous)
    best.problem = fmt::format(
        "found {} of the 5 fiducial discs{}: the target is partly out of view or occluded; frame "
        "the whole target",
        best_partial, any_ambiguous ? " but cannot tell which is which without the fifth" : "");
  else
    best.problem =
        "no target found: none of the blobs form the 5-disc fiducial pattern of layout.json (is "
        "this the right layout? is the target in view and in focus?)";
  return best;
}

}  // namespace tactres
