// Binary STL output of a relief mesh (stl.h).
#include "tactres/targets/stl.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <string>

#include "tactres/util/atomic_file.h"

namespace tactres {

void write_binary_stl(const std::filesystem::path& path, const TriangleMesh& mesh,
                      std::string_view header) {
  static_assert(std::endian::native == std::endian::little, "binary STL is little-endian");
  std::string bytes(80, ' ');
  // A header starting with "solid" makes some readers take the file for ASCII.
  bytes.replace(0, std::min<size_t>(80, header.size()), header.substr(0, 80));
  if (bytes.starts_with("solid")) bytes[0] = 'S';
  auto put = [&](const void* p, size_t n) { bytes.append(static_cast<const char*>(p), n); };
  const std::uint32_t count = std::uint32_t(mesh.triangles.size());
  put(&count, 4);
  bytes.reserve(bytes.size() + size_t(count) * 50);
  for (const auto& t : mesh.triangles) {
    const Vec3 &a = mesh.vertices[size_t(t[0])], &b = mesh.vertices[size_t(t[1])],
               &c = mesh.vertices[size_t(t[2])];
    const Vec3 u{b.x - a.x, b.y - a.y, b.z - a.z}, v{c.x - a.x, c.y - a.y, c.z - a.z};
    Vec3 n{u.y * v.z - u.z * v.y, u.z * v.x - u.x * v.z, u.x * v.y - u.y * v.x};
    const double len = std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    if (len > 0) n = {n.x / len, n.y / len, n.z / len};
    const float f[12] = {float(n.x), float(n.y), float(n.z), float(a.x), float(a.y), float(a.z),
                         float(b.x), float(b.y), float(b.z), float(c.x), float(c.y), float(c.z)};
    put(f, sizeof f);
    const std::uint16_t attr = 0;
    put(&attr, 2);
  }
  write_file_atomically(path, bytes);
}

void write_relief_stl(const std::filesystem::path& path, const TargetLayout& layout,
                      const StlOptions& options) {
  write_binary_stl(path, relief_mesh(layout, options));
}

}  // namespace tactres
