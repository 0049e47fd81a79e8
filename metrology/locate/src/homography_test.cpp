// The one plane homography routine of locate (homography.h), which the
// fiducial identification and the pose's initial guesses share.

#include "homography.h"

#include <array>
#include <cmath>
#include <vector>

#include <doctest/doctest.h>

using namespace tactres;
using namespace tactres::locate_detail;

namespace {

// A perspective map of the default layout's scale: mm -> px.
const Homography kTruth{21.0, 4.0, 640.0, -3.0, 19.0, 360.0, 0.004, -0.006, 1.0};

// The five fiducials' centres of the default layout, mm (TL, T3, TR, BL, BR).
const std::vector<Vec2> kDiscs{{2, 2}, {8.6, 2}, {22, 2}, {2, 22}, {22, 22}};

std::vector<Vec2> mapped(const Homography& H, const std::vector<Vec2>& pts) {
  std::vector<Vec2> out;
  for (const Vec2& p : pts) out.push_back(map_point(H, p));
  return out;
}

double max_error_px(const Homography& H, const std::vector<Vec2>& from, const std::vector<Vec2>& to) {
  double e = 0;
  for (size_t i = 0; i < from.size(); ++i) e = std::max(e, norm(map_point(H, from[i]) - to[i]));
  return e;
}

}  // namespace

TEST_CASE("homography: exact on 4 points in general position and on 5 consistent ones") {
  const std::vector<Vec2> corners{kDiscs[0], kDiscs[2], kDiscs[3], kDiscs[4]};
  const auto H4 = fit_homography(corners, mapped(kTruth, corners));
  REQUIRE(H4);
  CHECK(max_error_px(*H4, kDiscs, mapped(kTruth, kDiscs)) < 1e-9);
  const auto H5 = fit_homography(kDiscs, mapped(kTruth, kDiscs));
  REQUIRE(H5);
  CHECK(max_error_px(*H5, kDiscs, mapped(kTruth, kDiscs)) < 1e-9);
}

TEST_CASE("homography: degenerate point sets give no map") {
  const std::vector<Vec2> collinear{{0, 0}, {1, 0}, {2, 0}, {5, 0}, {7, 0}};
  CHECK_FALSE(fit_homography(collinear, mapped(kTruth, collinear)));
  const std::vector<Vec2> same(5, Vec2{3, 4});
  CHECK_FALSE(homography_dlt(same, mapped(kTruth, same)));
  CHECK_FALSE(fit_homography(std::vector<Vec2>(kDiscs.begin(), kDiscs.begin() + 3),
                             mapped(kTruth, std::vector<Vec2>(kDiscs.begin(), kDiscs.begin() + 3))));
}

TEST_CASE("homography: 4 points with a collinear triple leave a one-parameter family") {
  // TL, T3, TR (collinear) and BL: every member of the pencil maps all four.
  const std::vector<Vec2> four{kDiscs[0], kDiscs[1], kDiscs[2], kDiscs[3]};
  const std::vector<Vec2> image = mapped(kTruth, four);
  CHECK_FALSE(fit_homography(four, image));
  const auto sol = homography_dlt(four, image);
  REQUIRE(sol);
  CHECK_FALSE(sol->unique());
  for (double th : {0.3, 1.1, 2.5}) {
    Homography H;
    for (int k = 0; k < 9; ++k) H[k] = std::cos(th) * sol->runner_up[k] + std::sin(th) * sol->least_squares[k];
    CHECK(max_error_px(H, four, image) < 1e-6);
  }
}

TEST_CASE("homography: map_jacobian matches central differences") {
  const Vec2 p{9.0, 13.0};
  const MapJacobian J = map_jacobian(kTruth, p);
  const double h = 1e-5;
  const Vec2 dx = (1 / (2 * h)) * (map_point(kTruth, p + Vec2{h, 0}) - map_point(kTruth, p - Vec2{h, 0}));
  const Vec2 dy = (1 / (2 * h)) * (map_point(kTruth, p + Vec2{0, h}) - map_point(kTruth, p - Vec2{0, h}));
  CHECK(J.a == doctest::Approx(dx.x).epsilon(1e-7));
  CHECK(J.c == doctest::Approx(dx.y).epsilon(1e-7));
  CHECK(J.b == doctest::Approx(dy.x).epsilon(1e-7));
  CHECK(J.d == doctest::Approx(dy.y).epsilon(1e-7));
}
