#include "tactres/locate/rectified_search.h"

#include <algorithm>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <cmath>
#include <cstdint>
#include <vector>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

namespace tactres {

std::optional<CameraModel> rectifying_pinhole(const CameraModel& camera) {
  const int W = camera.imager_width(), H = camera.imager_height();
  const std::vector<double> k = camera.intrinsics();
  const double fx = k[0], fy = k[1], cx = k[2], cy = k[3];
  // Rays through the imager's border, as tangents of their angle off axis.
  std::vector<Vec2> border;
  const int n = 32;
  for (int i = 0; i <= n; ++i) {
    const double x = (W - 1) * double(i) / n, y = (H - 1) * double(i) / n;
    border.insert(border.end(), {{x, 0.0}, {x, H - 1.0}, {0.0, y}, {W - 1.0, y}});
  }
  double scale = 1.0;  // of the focal length
  for (const std::optional<Vec3>& ray : camera.unproject(border)) {
    if (!ray || !(ray->z > 1e-6 * std::hypot(ray->x, ray->y))) return std::nullopt;
    const double tx = ray->x / ray->z, ty = ray->y / ray->z;
    // The pinhole must put this ray inside the imager: |f t| <= room.
    const double room_x = tx < 0 ? cx : W - 1 - cx, room_y = ty < 0 ? cy : H - 1 - cy;
    if (std::abs(tx) > 0) scale = std::min(scale, room_x / (fx * std::abs(tx)));
    if (std::abs(ty) > 0) scale = std::min(scale, room_y / (fy * std::abs(ty)));
  }
  // Below half, the discs shrink too much to be found: crop instead.
  scale = std::max(scale, 0.5);
  return CameraModel::pinhole(fx * scale, fy * scale, cx, cy, W, H);
}

namespace {

struct RemapTables {
  cv::Mat map_x, map_y;  // CV_32F: where each rectified pixel looks in the capture
};

RemapTables remap_tables(const CameraModel& camera, const CameraModel& pinhole) {
  const int W = pinhole.imager_width(), H = pinhole.imager_height();
  const std::vector<double> k = pinhole.intrinsics();
  RemapTables t{cv::Mat(H, W, CV_32F), cv::Mat(H, W, CV_32F)};
  std::vector<Vec3> rays(W);
  std::vector<Vec2> px(W);
  std::vector<std::uint8_t> valid(W);
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) rays[x] = {(x - k[2]) / k[0], (y - k[3]) / k[1], 1.0};
    camera.project_into(rays, px, {}, {}, valid);
    float* mx = t.map_x.ptr<float>(y);
    float* my = t.map_y.ptr<float>(y);
    for (int x = 0; x < W; ++x) {
      const bool ok = valid[x] && std::isfinite(px[x].x) && std::isfinite(px[x].y);
      mx[x] = ok ? float(px[x].x) : -1.f;
      my[x] = ok ? float(px[x].y) : -1.f;
    }
  }
  return t;
}

// The tables cost ~45 ms for 1280x720 and depend on the two models only:
// a batch measured with one camera computes them once.
std::shared_ptr<const RemapTables> cached_remap_tables(const CameraModel& camera, const CameraModel& pinhole) {
  std::string key = camera.lensmodel_name();
  for (const CameraModel* m : {&camera, &pinhole}) {
    key += fmt::format(" {}x{}", m->imager_width(), m->imager_height());
    for (double v : m->intrinsics()) key += fmt::format(" {:.17g}", v);
  }
  static std::mutex mutex;
  static std::map<std::string, std::shared_ptr<const RemapTables>> cache;
  {
    std::lock_guard<std::mutex> lock(mutex);
    if (auto it = cache.find(key); it != cache.end()) return it->second;
  }
  auto tables = std::make_shared<const RemapTables>(remap_tables(camera, pinhole));
  std::lock_guard<std::mutex> lock(mutex);
  if (cache.size() >= 4) cache.clear();  // a few cameras per process at most
  cache.emplace(key, tables);
  return tables;
}

}  // namespace

cv::Mat rectify(const cv::Mat& image, const CameraModel& camera, const CameraModel& pinhole) {
  const std::shared_ptr<const RemapTables> t = cached_remap_tables(camera, pinhole);
  cv::Mat out;
  cv::remap(image, out, t->map_x, t->map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return out;
}

std::optional<RectifiedSearch> find_fiducials_rectified(const cv::Mat& luminance, const TargetLayout& layout,
                                                        const CameraModel& camera,
                                                        const FiducialSearchOptions& options) {
  std::optional<CameraModel> pinhole = rectifying_pinhole(camera);
  if (!pinhole) return std::nullopt;
  const cv::Mat rectified = rectify(luminance, camera, *pinhole);
  return RectifiedSearch{find_fiducials(rectified, layout, options), *pinhole};
}

std::optional<Vec2> unrectify_point(Vec2 rectified_px, const CameraModel& camera, const CameraModel& pinhole) {
  const std::vector<double> k = pinhole.intrinsics();
  const Vec3 ray{(rectified_px.x - k[2]) / k[0], (rectified_px.y - k[3]) / k[1], 1.0};
  const std::vector<ProjectedPoint> p = camera.project(std::span<const Vec3>(&ray, 1));
  if (!p[0].valid) return std::nullopt;
  return p[0].px;
}

}  // namespace tactres
