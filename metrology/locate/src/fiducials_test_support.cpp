#include "fiducials_test_support.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <doctest/doctest.h>
#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

namespace tactres::fiducial_test {

namespace {

constexpr double kPi = std::numbers::pi;

H3 mul(const H3& A, const H3& B) {
  H3 C{};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 3; ++k) C[3 * r + c] += A[3 * r + k] * B[3 * k + c];
  return C;
}

H3 homography(const TargetLayout& L, const View& v) {
  const double d = kPi / 180;
  auto rz = [](double a) {
    return std::array<double, 9>{
        std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1};
  };
  const std::array<double, 9> rx{1,
                                 0,
                                 0,
                                 0,
                                 std::cos(v.tilt_deg * d),
                                 -std::sin(v.tilt_deg * d),
                                 0,
                                 std::sin(v.tilt_deg * d),
                                 std::cos(v.tilt_deg * d)};
  const H3 R =
      mul(rz(v.roll_deg * d), mul(rz(v.tilt_axis_deg * d), mul(rx, rz(-v.tilt_axis_deg * d))));
  // [r1 r2 t] with the target centred on the optical axis.
  const H3 Rt{R[0], R[1], 0, R[3], R[4], 0, R[6], R[7], v.distance_mm};
  const H3 centre{1, 0, -L.width_mm / 2, 0, 1, -L.height_mm / 2, 0, 0, 1};
  const double cx = 0.5 * (v.size.width - 1) + v.shift_px.x;
  const double cy = 0.5 * (v.size.height - 1) + v.shift_px.y;
  const H3 K{v.focal_px, 0, cx, 0, v.focal_px, cy, 0, 0, 1};
  H3 H = mul(K, mul(Rt, centre));
  if (v.mirrored) H = mul(H3{-1, 0, double(v.size.width - 1), 0, 1, 0, 0, 0, 1}, H);
  return H;
}

std::vector<Vec2> disc_polygon(Vec2 c, double r, int n) {
  std::vector<Vec2> p;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * kPi * i / n;
    p.push_back({c.x + r * std::cos(a), c.y + r * std::sin(a)});
  }
  return p;
}

// Exact area centroid of the projected disc: a fine polygon, shoelace formula.
Vec2 projected_disc_centroid(const Projection& P, const Fiducial& f) {
  std::vector<Vec2> p;
  for (const Vec2& q : disc_polygon(f.center_mm, f.radius_mm, 720)) p.push_back(P(q));
  double A = 0, cx = 0, cy = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const Vec2 a = p[i], b = p[(i + 1) % p.size()];
    const double c = cross(a, b);
    A += c;
    cx += (a.x + b.x) * c;
    cy += (a.y + b.y) * c;
  }
  return {cx / (3 * A), cy / (3 * A)};
}

}  // namespace

Projection projection(const TargetLayout& L, const View& v) {
  Projection P;
  P.H = homography(L, v);
  P.k1 = v.k1;
  P.focal_px = v.focal_px;
  const double cx = 0.5 * (v.size.width - 1);
  P.principal_px = {v.mirrored ? v.size.width - 1 - cx : cx, 0.5 * (v.size.height - 1)};
  return P;
}

cv::Mat render(const TargetLayout& L, const Projection& P, cv::Size size, const RenderSpec& s) {
  const int ss = s.supersample;
  cv::Mat canvas = cv::Mat::zeros(size.height * ss, size.width * ss, CV_8U);
  constexpr int kShift = 4;
  auto to_canvas = [&](Vec2 mm) {
    const Vec2 p = P(mm);
    return cv::Point(static_cast<int>(std::lround(((p.x + 0.5) * ss - 0.5) * (1 << kShift))),
                     static_cast<int>(std::lround(((p.y + 0.5) * ss - 0.5) * (1 << kShift))));
  };
  for (const ArtworkShape& a : L.artwork) {
    std::vector<Vec2> mm;
    if (a.role == ArtworkShape::Role::patch && s.drop_patch) continue;
    if (a.role == ArtworkShape::Role::fiducial) {
      if (s.drop_fiducials) continue;
      bool hide = false;
      for (const Fiducial& f : L.fiducials)
        if (std::abs(f.center_mm.x - a.center_mm.x) < 1e-9 &&
            std::abs(f.center_mm.y - a.center_mm.y) < 1e-9)
          hide = std::find(s.hidden.begin(), s.hidden.end(), f.id) != s.hidden.end();
      if (hide) continue;
    }
    switch (a.kind) {
      case ArtworkShape::Kind::rect: {
        const Vec2 c[4] = {{a.rect_mm.x0, a.rect_mm.y0},
                           {a.rect_mm.x1, a.rect_mm.y0},
                           {a.rect_mm.x1, a.rect_mm.y1},
                           {a.rect_mm.x0, a.rect_mm.y1}};
        const int sub = P.k1 == 0 ? 1 : 16;
        for (int e = 0; e < 4; ++e)
          for (int t = 0; t < sub; ++t)
            mm.push_back(c[e] + (double(t) / sub) * (c[(e + 1) % 4] - c[e]));
        break;
      }
      case ArtworkShape::Kind::disc:
        mm = disc_polygon(a.center_mm, a.radius_mm, 720);
        break;
      case ArtworkShape::Kind::polygon:
        mm = a.polygon_mm;
        break;
    }
    std::vector<cv::Point> pts;
    for (const Vec2& q : mm) pts.push_back(to_canvas(q));
    cv::fillPoly(canvas, std::vector<std::vector<cv::Point>>{pts}, cv::Scalar(255), cv::LINE_8,
                 kShift);
  }
  cv::Mat cov;
  canvas.convertTo(canvas, CV_32F, 1.0 / 255);
  cv::resize(canvas, cov, size, 0, 0, cv::INTER_AREA);
  return s.ground + (s.ink - s.ground) * cov;
}

cv::Mat make_image(const Case& c, const Projection& P) {
  cv::Mat img = render(c.layout, P, c.view.size, c.spec);
  if (c.ring_sign != 0) {
    cv::Mat gx, gy, mag;
    cv::GaussianBlur(img, img, cv::Size(0, 0), 1.2);
    cv::Sobel(img, gx, CV_32F, 1, 0);
    cv::Sobel(img, gy, CV_32F, 0, 1);
    cv::magnitude(gx, gy, mag);
    double mx;
    cv::minMaxLoc(mag, nullptr, &mx);
    img = (c.ring_sign > 0 ? 0.3 : 0.6) + (c.ring_sign > 0 ? 0.45 : -0.45) / mx * mag;
  }
  if (c.directional) {
    cv::Mat gx, gy;
    cv::GaussianBlur(img, img, cv::Size(0, 0), 1.2);
    cv::Sobel(img, gx, CV_32F, 1, 0);
    cv::Sobel(img, gy, CV_32F, 0, 1);
    const double a = c.light_azimuth_deg * kPi / 180;
    cv::Mat d = std::cos(a) * gx + std::sin(a) * gy;
    double lo, hi;
    cv::minMaxLoc(d, &lo, &hi);
    img = 0.5 + 0.3 / std::max(-lo, hi) * d;
  }
  if (c.blur_sigma_px > 0) cv::GaussianBlur(img, img, cv::Size(0, 0), c.blur_sigma_px);
  if (c.gradient) {
    for (int y = 0; y < img.rows; ++y) {
      float* row = img.ptr<float>(y);
      for (int x = 0; x < img.cols; ++x)
        row[x] *= static_cast<float>(1.0 / 3.0 + (2.0 / 3.0) * x / (img.cols - 1));
    }
  }
  if (c.noise_sigma > 0) {
    cv::Mat noise(img.size(), CV_32F);
    cv::RNG rng(12345);
    rng.fill(noise, cv::RNG::NORMAL, 0, c.noise_sigma);
    img += noise;
  }
  return img;
}

Outcome run(const Case& c) {
  Outcome o;
  o.P = projection(c.layout, c.view);
  const cv::Mat img = make_image(c, o.P);
  o.result = find_fiducials(img, c.layout);
  double ss = 0;
  for (const FiducialDetection& d : o.result.discs) {
    const auto it = std::find_if(c.layout.fiducials.begin(), c.layout.fiducials.end(),
                                 [&](const Fiducial& f) { return f.id == d.id; });
    REQUIRE(it != c.layout.fiducials.end());
    const Vec2 e = d.centroid_px - projected_disc_centroid(o.P, *it);
    o.max_err_px = std::max(o.max_err_px, norm(e));
    ss += dot(e, e);
  }
  if (!o.result.discs.empty()) o.rms_err_px = std::sqrt(ss / o.result.discs.size());
  MESSAGE(fmt::format(
      "{:<34} found={} n={} pol={} max_err={:.4f} px rms_err={:.4f} px fit_rms={:.3f} px{}", c.name,
      o.result.found, o.result.discs.size(),
      o.result.shaded ? "shaded" : (o.result.dark_on_light ? "dark" : "light"), o.max_err_px,
      o.rms_err_px, o.result.fit_rms_px,
      o.result.problem.empty() ? "" : " problem: " + o.result.problem));
  return o;
}

std::vector<std::string> ids(const FiducialSearchResult& r) {
  std::vector<std::string> v;
  for (const auto& d : r.discs) v.push_back(d.id);
  return v;
}

void check_all_found(const Outcome& o, double max_err_px) {
  REQUIRE(o.result.found);
  CHECK(o.result.problem.empty());
  CHECK(ids(o.result) == kAll);
  CHECK(o.max_err_px < max_err_px);
}

Case base_case(std::string name) {
  Case c;
  c.name = std::move(name);
  c.layout = make_layout({});
  return c;
}

}  // namespace tactres::fiducial_test
