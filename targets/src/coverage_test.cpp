#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <doctest/doctest.h>

#include "tactres/targets/coverage.h"

using namespace tactres;

namespace {

ArtworkShape rect_shape(RectMm r) {
  ArtworkShape s;
  s.kind = ArtworkShape::Kind::rect;
  s.rect_mm = r;
  return s;
}
ArtworkShape disc_shape(Vec2 c, double r) {
  ArtworkShape s;
  s.kind = ArtworkShape::Kind::disc;
  s.center_mm = c;
  s.radius_mm = r;
  return s;
}
ArtworkShape polygon_shape(std::vector<Vec2> pts) {
  ArtworkShape s;
  s.kind = ArtworkShape::Kind::polygon;
  s.polygon_mm = std::move(pts);
  return s;
}
std::vector<Vec2> reversed(std::vector<Vec2> v) { return {v.rbegin(), v.rend()}; }

// Circular segment beyond a chord at distance d from the centre.
double segment_area(double r, double d) { return r * r * std::acos(d / r) - d * std::sqrt(r * r - d * d); }

}  // namespace

TEST_CASE("coverage: rect against squares, a rotated square and a triangle") {
  const ArtworkShape s = rect_shape({1.0, 2.0, 3.0, 2.5});
  CHECK(intersection_area_mm2(s, RectMm{0, 0, 10, 10}) == doctest::Approx(1.0));
  CHECK(intersection_area_mm2(s, RectMm{2.5, 2.25, 3.5, 4}) == doctest::Approx(0.125));
  CHECK(intersection_area_mm2(s, RectMm{3.0, 0, 4, 4}) == 0.0);  // touching only

  // A diamond centred on the rect's centre (2, 2.25) with half-diagonal 0.25
  // lies wholly inside: area 2 * 0.25^2. Both windings.
  const std::vector<Vec2> diamond{{2.25, 2.25}, {2, 2.5}, {1.75, 2.25}, {2, 2.0}};
  CHECK(intersection_area_mm2(s, diamond) == doctest::Approx(0.125));
  CHECK(intersection_area_mm2(s, reversed(diamond)) == doctest::Approx(0.125));
  // Shifted up by 0.25, its top half sticks out of y1 = 2.5: half remains.
  std::vector<Vec2> up = diamond;
  for (Vec2& p : up) p.y += 0.25;
  CHECK(intersection_area_mm2(s, up) == doctest::Approx(0.0625));

  // Triangle (0,2)-(4,2)-(0,6): inside y in [2, 2.5] and x in [1, 3] the
  // hypotenuse x + y = 6 is not reached, so the overlap is the full 1 x 0.5.
  const std::vector<Vec2> tri{{0, 2}, {4, 2}, {0, 6}};
  CHECK(intersection_area_mm2(s, tri) == doctest::Approx(1.0));
  const std::vector<Vec2> tri2{{0, 2}, {3, 2}, {0, 5}};  // x + y = 5 cuts a corner
  CHECK(intersection_area_mm2(s, tri2) == doctest::Approx(1.0 - 0.5 * 0.5 * 0.5));
  CHECK(intersection_area_mm2(s, std::vector<Vec2>{{0, 0}, {1, 1}}) == 0.0);
}

TEST_CASE("coverage: discs are exact against half planes, chords and tilings") {
  const Vec2 c{5.0, 5.0};
  const double r = 1.5;
  const ArtworkShape d = disc_shape(c, r);
  const double full = std::numbers::pi * r * r;
  CHECK(intersection_area_mm2(d, RectMm{0, 0, 10, 10}) == doctest::Approx(full).epsilon(1e-14));
  CHECK(intersection_area_mm2(d, RectMm{5, 0, 10, 10}) == doctest::Approx(full / 2).epsilon(1e-14));
  CHECK(intersection_area_mm2(d, RectMm{5.4, 0, 10, 10}) ==
        doctest::Approx(segment_area(r, 0.4)).epsilon(1e-13));
  CHECK(intersection_area_mm2(d, RectMm{7, 7, 8, 8}) == 0.0);
  // A square wholly inside the disc.
  CHECK(intersection_area_mm2(d, RectMm{4.5, 4.5, 5.5, 5.5}) == doctest::Approx(1.0));
  // A chord cut by a tilted polygon, both windings: the half plane
  // x + y >= 10 + sqrt(2) * 0.7 is at distance 0.7 from the centre.
  const double k = 10 + std::sqrt(2.0) * 0.7;
  const std::vector<Vec2> tilted{{k - 20, 20}, {k, 0}, {30, 0}, {30, 30}, {k - 30, 30}};
  CHECK(intersection_area_mm2(d, tilted) == doctest::Approx(segment_area(r, 0.7)).epsilon(1e-13));
  CHECK(intersection_area_mm2(d, reversed(tilted)) ==
        doctest::Approx(segment_area(r, 0.7)).epsilon(1e-13));

  // Fan triangles around a random interior point tile a square: the pieces
  // must sum to the whole disc, whatever each piece's shape.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(3.2, 6.8);
  for (int trial = 0; trial < 20; ++trial) {
    const Vec2 hub{u(rng), u(rng)};
    const std::vector<Vec2> sq{{3.4, 3.4}, {6.6, 3.4}, {6.6, 6.6}, {3.4, 6.6}};
    double sum = 0;
    for (int i = 0; i < 4; ++i) {
      const std::vector<Vec2> tri{hub, sq[size_t(i)], sq[size_t((i + 1) % 4)]};
      sum += intersection_area_mm2(d, trial % 2 ? reversed(tri) : tri);
    }
    CHECK(sum == doctest::Approx(full).epsilon(1e-13));
  }
  // Pixel tiling at a non-integer pitch.
  double sum = 0;
  const double px = 0.0937;
  for (int j = 0; j * px < 10; ++j)
    for (int i = 0; i * px < 10; ++i)
      sum += intersection_area_mm2(d, RectMm{i * px, j * px, (i + 1) * px, (j + 1) * px});
  CHECK(sum == doctest::Approx(full).epsilon(1e-12));
}

TEST_CASE("coverage: a non-convex polygon is clipped exactly") {
  // L shape: [0,2]x[0,1] plus [0,1]x[1,2], area 3.
  const std::vector<Vec2> L{{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}};
  for (const auto& pts : {L, reversed(L)}) {
    const ArtworkShape s = polygon_shape(pts);
    CHECK(intersection_area_mm2(s, RectMm{-1, -1, 3, 3}) == doctest::Approx(3.0));
    CHECK(intersection_area_mm2(s, RectMm{0.5, 0.5, 1.5, 1.5}) == doctest::Approx(0.75));
    const std::vector<Vec2> square{{0.5, 0.5}, {1.5, 0.5}, {1.5, 1.5}, {0.5, 1.5}};
    CHECK(intersection_area_mm2(s, square) == doctest::Approx(0.75));
    // The notch corner (1,1) cut by the line x + y = 2.5: above it only the
    // two arms contribute.
    const std::vector<Vec2> beyond{{2.5, 0}, {5, 0}, {5, 5}, {0, 5}, {0, 2.5}};
    CHECK(intersection_area_mm2(s, beyond) == doctest::Approx(0.125 + 0.125));
    double sum = 0;
    const double px = 0.13;
    for (int j = 0; j < 17; ++j)
      for (int i = 0; i < 17; ++i)
        sum += intersection_area_mm2(s, RectMm{i * px, j * px, (i + 1) * px, (j + 1) * px});
    CHECK(sum == doctest::Approx(3.0).epsilon(1e-13));
  }
}

TEST_CASE("coverage: the index returns exactly the shapes whose bounds meet the window") {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> pos(0, 20), size(0.01, 2);
  std::vector<ArtworkShape> shapes;
  for (int i = 0; i < 300; ++i) {
    const double x = pos(rng), y = pos(rng);
    if (i % 3 == 0)
      shapes.push_back(disc_shape({x, y}, 0.5 * size(rng)));
    else
      shapes.push_back(rect_shape({x, y, x + size(rng), y + size(rng)}));
  }
  const ArtworkIndex index(shapes);
  std::vector<int> got;
  for (int q = 0; q < 500; ++q) {
    const double x = pos(rng) - 1, y = pos(rng) - 1, s = q % 2 ? 0.05 : size(rng) * 3;
    const RectMm w{x, y, x + s, y + s};
    index.query(w, got);
    std::vector<int> want;
    for (int i = 0; i < int(shapes.size()); ++i) {
      const RectMm b = shapes[size_t(i)].bounds_mm();
      if (b.x0 <= w.x1 && w.x0 <= b.x1 && b.y0 <= w.y1 && w.y0 <= b.y1) want.push_back(i);
    }
    REQUIRE(got == want);
  }
  CHECK(ArtworkIndex(std::vector<ArtworkShape>{}).query(RectMm{0, 0, 1, 1}).empty());
}
