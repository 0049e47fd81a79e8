#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <map>
#include <random>
#include <set>

#include <doctest/doctest.h>

#include "tactres/util/atomic_file.h"
#include "tactres/targets/coverage.h"
#include "tactres/targets/stl.h"

using namespace tactres;
namespace fs = std::filesystem;

namespace {

struct ParsedStl {
  std::vector<std::array<float, 3>> vertices;  // welded by exact float value
  std::vector<std::array<int, 3>> triangles;
  std::vector<std::array<float, 3>> normals;
};

ParsedStl parse_binary_stl(const std::string& bytes) {
  REQUIRE(bytes.size() >= 84);
  std::uint32_t n = 0;
  std::memcpy(&n, bytes.data() + 80, 4);
  REQUIRE(bytes.size() == 84 + size_t(n) * 50);
  ParsedStl out;
  std::map<std::array<float, 3>, int> ids;
  for (std::uint32_t t = 0; t < n; ++t) {
    float f[12];
    std::memcpy(f, bytes.data() + 84 + size_t(t) * 50, sizeof f);
    out.normals.push_back({f[0], f[1], f[2]});
    std::array<int, 3> tri{};
    for (int k = 0; k < 3; ++k) {
      const std::array<float, 3> v{f[3 + 3 * k], f[4 + 3 * k], f[5 + 3 * k]};
      auto [it, fresh] = ids.emplace(v, int(out.vertices.size()));
      if (fresh) out.vertices.push_back(v);
      tri[size_t(k)] = it->second;
    }
    out.triangles.push_back(tri);
  }
  return out;
}

// Checks closedness and orientation; returns the enclosed volume.
double check_closed_outward(const ParsedStl& m) {
  std::map<std::pair<int, int>, int> directed;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) ++directed[{t[size_t(k)], t[size_t((k + 1) % 3)]}];
  int bad_directed = 0, bad_undirected = 0;
  for (const auto& [e, c] : directed) {
    bad_directed += c != 1;
    const auto twin = directed.find({e.second, e.first});
    bad_undirected += twin == directed.end() || twin->second != 1;
  }
  CHECK(bad_directed == 0);    // each directed edge once
  CHECK(bad_undirected == 0);  // so each undirected edge by exactly two triangles

  double six_v = 0;
  int bad_normals = 0, degenerate = 0;
  for (size_t i = 0; i < m.triangles.size(); ++i) {
    const auto& t = m.triangles[i];
    const auto &a = m.vertices[size_t(t[0])], &b = m.vertices[size_t(t[1])], &c = m.vertices[size_t(t[2])];
    const double u[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
    const double v[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
    const double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (len == 0) {
      ++degenerate;
      continue;
    }
    const auto& s = m.normals[i];
    const double agree = (n[0] * s[0] + n[1] * s[1] + n[2] * s[2]) / len;
    bad_normals += agree < 0.999;
    six_v += a[0] * (double(b[1]) * c[2] - double(b[2]) * c[1]) +
             a[1] * (double(b[2]) * c[0] - double(b[0]) * c[2]) +
             a[2] * (double(b[0]) * c[1] - double(b[1]) * c[0]);
  }
  CHECK(degenerate == 0);
  CHECK(bad_normals == 0);
  CHECK(six_v > 0);
  return six_v / 6;
}

double expected_volume(const TargetLayout& L, const StlOptions& o) {
  double footprint = 0;
  for (const ArtworkShape& s : L.artwork) footprint += std::abs(signed_area_mm2(mesh_footprint_mm(s, o)));
  return L.width_mm * L.height_mm * L.base_thickness_mm + footprint * L.relief_height_mm;
}

ParsedStl write_and_parse(const TargetLayout& L, const StlOptions& o) {
  const fs::path p = fs::temp_directory_path() /
                     ("tactres-stl-test-" + std::to_string(std::random_device{}()) + ".stl");
  write_relief_stl(p, L, o);
  const std::string bytes = read_file(p);
  fs::remove(p);
  CHECK(bytes.substr(0, 5) != "solid");
  return parse_binary_stl(bytes);
}

ArtworkShape rect(double x0, double y0, double x1, double y1) {
  ArtworkShape s;
  s.rect_mm = {x0, y0, x1, y1};
  return s;
}

}  // namespace

TEST_CASE("stl: the default target is one closed, outward, exact-volume mesh") {
  const TargetLayout L = make_layout({});
  const StlOptions o;
  const TriangleMesh mesh = relief_mesh(L, o);
  // The in-memory mesh in double: the relief part alone to 1e-9.
  const double plate = L.width_mm * L.height_mm * L.base_thickness_mm;
  CHECK((mesh.volume_mm3() - plate) ==
        doctest::Approx(expected_volume(L, o) - plate).epsilon(1e-9));

  const ParsedStl m = write_and_parse(L, o);
  CHECK(m.triangles.size() == mesh.triangles.size());
  const double v = check_closed_outward(m);
  CHECK(std::abs(v / expected_volume(L, o) - 1) < 1e-6);
  // Euler characteristic of a closed genus-0 surface: V - E + F = 2 (the
  // relief is a single slab; raised shapes add no handles).
  const long long V = (long long)m.vertices.size(), F = (long long)m.triangles.size();
  CHECK(V - 3 * F / 2 + F == 2);
  std::set<float> levels;
  for (const auto& p : m.vertices) levels.insert(p[2]);
  CHECK(levels == std::set<float>{0.0f, 2.0f, float(2.0 + 0.1)});
}

TEST_CASE("stl: touching and nested shapes, discs and polygons stay manifold") {
  std::mt19937 rng(11);
  std::bernoulli_distribution fill(0.45);
  for (int trial = 0; trial < 6; ++trial) {
    TargetLayout L;
    L.width_mm = 20;
    L.height_mm = 20;
    L.relief_height_mm = 0.3;
    // Random cells on a 0.5 mm grid: touching edges, holes, islands in
    // holes. Cells that would meet only at a corner get a neighbour filled,
    // since a point contact cannot be a 2-manifold (tested below).
    constexpr int kCols = 36, kRows = 18;
    std::vector<char> on(kCols * kRows);
    for (char& c : on) c = fill(rng);
    auto cell = [&](int i, int j) -> char& { return on[size_t(j * kCols + i)]; };
    for (bool changed = true; changed;) {
      changed = false;
      for (int j = 0; j + 1 < kRows; ++j)
        for (int i = 0; i + 1 < kCols; ++i) {
          const bool a = cell(i, j), b = cell(i + 1, j), c = cell(i, j + 1), d = cell(i + 1, j + 1);
          if (a && d && !b && !c) cell(i + 1, j) = 1, changed = true;
          if (b && c && !a && !d) cell(i, j) = 1, changed = true;
        }
    }
    for (int j = 0; j < kRows; ++j)
      for (int i = 0; i < kCols; ++i)
        if (cell(i, j)) L.artwork.push_back(rect(1 + 0.5 * i, 1 + 0.5 * j, 1.5 + 0.5 * i, 1.5 + 0.5 * j));
    // A ring of four rects around an island rect.
    for (const auto& r : {rect(2, 12, 8, 13), rect(2, 17, 8, 18), rect(2, 13, 3, 17), rect(7, 13, 8, 17),
                          rect(4, 14, 6, 16)})
      L.artwork.push_back(r);
    ArtworkShape d;
    d.kind = ArtworkShape::Kind::disc;
    d.center_mm = {10, 15};
    d.radius_mm = 1.2;
    L.artwork.push_back(d);
    ArtworkShape star;  // concave
    star.kind = ArtworkShape::Kind::polygon;
    for (int k = 0; k < 10; ++k) {
      const double a = 2 * 3.14159265358979 * k / 10, r = k % 2 ? 0.7 : 1.8;
      star.polygon_mm.push_back({15 + r * std::cos(a), 15 + r * std::sin(a)});
    }
    L.artwork.push_back(star);
    // A triangle standing on part of a rect's edge: a partly shared edge.
    ArtworkShape tri;
    tri.kind = ArtworkShape::Kind::polygon;
    tri.polygon_mm = {{17.5, 12}, {18.5, 12}, {18, 11}};
    L.artwork.push_back(tri);
    L.artwork.push_back(rect(17, 12, 19, 13));

    StlOptions o;
    o.disc_segments = 8 + 13 * trial;
    INFO("trial " << trial);
    const ParsedStl m = write_and_parse(L, o);
    const double v = check_closed_outward(m);
    CHECK(std::abs(v / expected_volume(L, o) - 1) < 1e-6);
  }
}

TEST_CASE("stl: overlapping or out-of-plate shapes and bad options are refused") {
  TargetLayout L;
  L.artwork = {rect(1, 1, 3, 3), rect(2, 2, 4, 4)};
  CHECK_THROWS_WITH_AS(relief_mesh(L), doctest::Contains("overlap"), std::invalid_argument);
  L.artwork = {rect(0, 1, 3, 3)};
  CHECK_THROWS_WITH_AS(relief_mesh(L), doctest::Contains("inside"), std::invalid_argument);
  L.artwork = {rect(1, 1, 3, 3)};
  StlOptions o;
  o.disc_segments = 3;
  CHECK_THROWS_WITH_AS(relief_mesh(L, o), doctest::Contains("disc segments"), std::invalid_argument);
  CHECK_THROWS_AS(write_relief_stl("/nonexistent-dir/x.stl", L), std::runtime_error);
  // Corner to corner, and a triangle's apex on an edge: point contacts.
  L.artwork = {rect(1, 1, 2, 2), rect(2, 2, 3, 3)};
  CHECK_THROWS_WITH_AS(relief_mesh(L), doctest::Contains("single point near (2, 2) mm"),
                       std::invalid_argument);
  ArtworkShape tri;
  tri.kind = ArtworkShape::Kind::polygon;
  tri.polygon_mm = {{1.5, 3}, {2.5, 3}, {2, 2}};
  L.artwork = {rect(1, 1, 3, 2), tri};
  CHECK_THROWS_WITH_AS(relief_mesh(L), doctest::Contains("single point"), std::invalid_argument);
}
