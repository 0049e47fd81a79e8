#include "tactres/simulate/renderer.h"

#include <cmath>
#include <numbers>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "tactres/util/stopwatch.h"
#include "tactres/simulate/effects/illumination.h"
#include "tactres/simulate/effects/psf.h"
#include "tactres/simulate/effects/relief_field.h"
#include "tactres/simulate/effects/sensor_model.h"
#include "tactres/camera/target_view.h"
#include "tactres/simulate/effects/vignetting.h"
#include "tactres/targets/coverage.h"

namespace tactres {

struct TargetRadiance::Impl {
  const Scene& scene;
  const TargetLayout& layout;
  std::optional<ArtworkIndex> index;      // albedo coverage, or rigid relief
  std::optional<ReliefField> relief;      // relief under contact
  std::optional<IlluminationField> light;
  const ShadingEffect* shading = nullptr;
  std::vector<std::array<double, 3>> light_dirs;  // unit vectors, weighted
  Vec2 target_center;                             // the light map's origin

  Impl(const Scene& s, const TargetLayout& l)
      : scene(s), layout(l), target_center{0.5 * l.width_mm, 0.5 * l.height_mm} {
    const ContactEffect* contact = s.find<ContactEffect>();
    if (s.target == TargetKind::relief && contact)
      relief.emplace(l, contact->sigma_mm, contact->depth_fraction * l.relief_height_mm);
    else
      index.emplace(l.artwork, 0.0);
    shading = s.find<ShadingEffect>();
    if (shading)
      for (const Light& li : shading->lights) {
        const double az = li.azimuth_deg * std::numbers::pi / 180, el = li.elevation_deg * std::numbers::pi / 180;
        light_dirs.push_back({li.weight * std::cos(el) * std::cos(az), li.weight * std::cos(el) * std::sin(az),
                              li.weight * std::sin(el)});
      }
    if (const IlluminationOptions* ill = s.find<IlluminationOptions>())
      light.emplace(target_illumination(*ill, l.width_mm, l.height_mm));
  }

  double coverage(const Vec2 quad[4]) const {
    RectMm box{quad[0].x, quad[0].y, quad[0].x, quad[0].y};
    for (int k = 1; k < 4; ++k) box = bounding_union(box, {quad[k].x, quad[k].y, quad[k].x, quad[k].y});
    thread_local std::vector<int> hits;
    index->query(box, hits);
    if (hits.empty()) return 0.0;
    const double area = std::abs(signed_area_mm2(std::span<const Vec2>(quad, 4)));
    if (!(area > 0)) return 0.0;
    double covered = 0;
    for (int i : hits) covered += intersection_area_mm2(layout.artwork[i], std::span<const Vec2>(quad, 4));
    return std::min(1.0, covered / area);
  }

  // Gel coating under the lights: Lambert, or its first order in the slope.
  // With a light map (light_path) the one light at point c is
  // w l = (t_x, t_y, 1), t = E_t / E_n there.
  double shade(const ReliefField::Sample& s, Vec2 c) const {
    const double nx = -s.slope_x, ny = -s.slope_y;
    const double inv_len = shading->model == ShadingEffect::Model::lambert
                               ? 1.0 / std::sqrt(1 + nx * nx + ny * ny)
                               : 1.0;
    auto one = [&](double lx, double ly, double lz) {
      const double d = (nx * lx + ny * ly + lz) * inv_len;
      return shading->model == ShadingEffect::Model::lambert ? std::max(0.0, d) : d;
    };
    double r = 0;
    if (shading->light_map) {
      const Vec2 t = shading->light_map->in_plane_fraction_at(c - target_center);
      r = one(t.x, t.y, 1.0);
    } else {
      for (const auto& l : light_dirs) r += one(l[0], l[1], l[2]);
    }
    return shading->albedo * r + shading->ambient;
  }

  double over_footprint(const Vec2 q[4]) const {
    const Vec2 c = 0.25 * (q[0] + q[1] + q[2] + q[3]);
    double value;
    if (scene.target == TargetKind::albedo) {
      const double cov = coverage(q);
      value = scene.ground_reflectance + (scene.ink_reflectance - scene.ground_reflectance) * cov;
    } else if (relief) {
      const ReliefField::Sample s = relief->at(c);
      value = shading ? shade(s, c) : s.height_mm / relief->peak_height_mm();
    } else {
      value = coverage(q);  // rigid relief, no gel: the normalised height
    }
    if (light) value *= light->relative_irradiance(c);
    return value;
  }
};

TargetRadiance::TargetRadiance(const Scene& scene, const TargetLayout& layout)
    : impl_(std::make_unique<Impl>(scene, layout)) {}
TargetRadiance::~TargetRadiance() = default;
double TargetRadiance::over_footprint(const Vec2 quad[4]) const { return impl_->over_footprint(quad); }

namespace {


// cos of the chief-ray angle at every pixel, from the lens model's rays on a
// coarse lattice (the field is smooth), bilinearly upsampled.
cv::Mat cos_chief_ray(const CameraModel& camera, int w, int h) {
  const int step = 8;
  const int nx = w / step + 2, ny = h / step + 2;
  std::vector<Vec2> px;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) px.push_back({double(i * step), double(j * step)});
  const auto rays = camera.unproject(px);
  cv::Mat coarse(ny, nx, CV_32F);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const auto& r = rays[j * nx + i];
      coarse.at<float>(j, i) =
          r ? static_cast<float>(r->z / std::sqrt(r->x * r->x + r->y * r->y + r->z * r->z)) : 0.f;
    }
  cv::Mat out(h, w, CV_32F);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double gx = double(x) / step, gy = double(y) / step;
      const int i = int(gx), j = int(gy);
      const double a = gx - i, b = gy - j;
      out.at<float>(y, x) = static_cast<float>(
          (1 - b) * ((1 - a) * coarse.at<float>(j, i) + a * coarse.at<float>(j, i + 1)) +
          b * ((1 - a) * coarse.at<float>(j + 1, i) + a * coarse.at<float>(j + 1, i + 1)));
    }
  return out;
}

}  // namespace

RenderResult render_scene(const Scene& scene, const TargetLayout& layout, const CameraModel& camera,
                          std::optional<std::uint64_t> seed) {
  RenderResult result;
  Stopwatch t0;
  const int W = camera.imager_width(), H = camera.imager_height();
  const int s = scene.supersampling;
  const TargetView view(camera, scene.rt_camera_from_target(layout));
  // Pixel (x, y) covers [x - 0.5, x + 0.5]; the lattice covers every
  // sub-pixel corner, with a margin for bilinear lookups.
  const InverseMap map(view, -1.0, -1.0, W, H, 4.0);
  const TargetRadiance radiance(scene, layout);
  result.stage_seconds.push_back({"lens_map", t0.seconds()});

  t0.restart();
  cv::Mat super(H * s, W * s, CV_32F);
  cv::parallel_for_(cv::Range(0, H * s), [&](const cv::Range& rows) {
    std::vector<std::optional<Vec2>> top(W * s + 1), bottom(W * s + 1);
    auto corner_row = [&](int j, std::vector<std::optional<Vec2>>& out) {
      const double y = -0.5 + double(j) / s;
      for (int i = 0; i <= W * s; ++i) out[i] = map.at(-0.5 + double(i) / s, y);
    };
    corner_row(rows.start, top);
    for (int j = rows.start; j < rows.end; ++j) {
      corner_row(j + 1, bottom);
      float* row = super.ptr<float>(j);
      for (int i = 0; i < W * s; ++i) {
        if (!(top[i] && top[i + 1] && bottom[i] && bottom[i + 1])) {
          row[i] = 0.f;  // the ray misses the target plane
          continue;
        }
        const Vec2 q[4] = {*top[i], *top[i + 1], *bottom[i + 1], *bottom[i]};
        row[i] = static_cast<float>(radiance.over_footprint(q));
      }
      std::swap(top, bottom);
    }
  });
  result.stage_seconds.push_back({"target_plane", t0.seconds()});

  if (const PsfOptions* psf = scene.find<PsfOptions>()) {
    t0.restart();
    apply_psf(super, *psf, 1.0 / s);
    result.stage_seconds.push_back({"blur", t0.seconds()});
  }

  cv::Mat image;
  if (s == 1) image = super;
  else cv::resize(super, image, cv::Size(W, H), 0, 0, cv::INTER_AREA);  // exact box mean for integer s

  if (const VignettingEffect* v = scene.find<VignettingEffect>()) {
    t0.restart();
    apply_vignetting(image, cos_chief_ray(camera, W, H), v->exponent);
    result.stage_seconds.push_back({"vignetting", t0.seconds()});
  }
  if (const SensorOptions* sensor = scene.find<SensorOptions>()) {
    t0.restart();
    SensorOptions o = *sensor;
    if (seed) o.seed = *seed;
    image = apply_sensor(image, o);
    result.bits = o.bit_depth;
    result.stage_seconds.push_back({"sensor", t0.seconds()});
  }
  result.image = image;
  return result;
}

}  // namespace tactres
