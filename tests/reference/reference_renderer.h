// An independent reference renderer for tactres' end-to-end tests (issue 12).
//
// It shares no code with tactres: it includes no tactres header and links no
// tactres library. It reads the layout JSON itself (nlohmann-json), projects
// through mrcal's C API (a .cameramodel file, or a pinhole built in memory),
// and writes plain files with OpenImageIO. Its model is deliberately simple:
//
//   albedo: I(x, y) = ground + (ink - ground) * (G_sigma * ink_indicator)(x, y)
//   relief: I(x, y) = level + gain_per_slope * l . grad(G_sigma * h)(x, y),
//           h = relief_mm on every artwork shape and 0 elsewhere,
//
// with G_sigma an isotropic Gaussian of sigma_mm in the target plane, both
// evaluated analytically, and point sampling at pixel centres (no pixel
// aperture). Its truth is therefore m(f) = exp(-2 pi^2 sigma_mm^2 f^2).
//
// Frames (as in docs/CONVENTIONS.md, but implemented here independently):
// target frame in mm, origin at the top-left of the target, x right, y down,
// z into the target; camera frame x right, y down, z along the optical axis;
// pixel (0, 0) is the centre of the top-left pixel.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

extern "C" {
#include <mrcal/mrcal.h>
}

namespace reference {

using Vec2 = std::array<double, 2>;
using Vec3 = std::array<double, 3>;
using Mat3 = std::array<Vec3, 3>;  // row-major: m[row][col]

struct RectMm {
  double x0_mm = 0, y0_mm = 0, x1_mm = 0, y1_mm = 0;  // x0 < x1, y0 < y1
};

// ---- the layout (layout_reader.cpp) ---------------------------------------

struct LayoutElement {
  int group = 0;
  int element = 0;
  double lp_per_mm = 0;
  double bar_width_mm = 0;
  bool horizontal_bars = true;  // long side along x: resolves detail along y
  std::vector<RectMm> bars_mm;
  std::string orientation() const { return horizontal_bars ? "horizontal_bars" : "vertical_bars"; }
  Vec2 center_mm() const;
};

struct Layout {
  double width_mm = 0, height_mm = 0;
  double relief_height_mm = 0.1;
  std::vector<LayoutElement> elements;
  // Every artwork shape as non-overlapping axis-aligned rectangles: rects as
  // they are, discs and polygons cut into thin horizontal scanline strips.
  std::vector<RectMm> ink_rects_mm;
  int artwork_shapes = 0;
};

// Reads a tactres.target/1 layout. Discs become strips_per_disc strips, each
// as wide as the disc's exact area between its two scanlines; polygons become
// strips of height <= max_polygon_strip_mm, each spanning the polygon's
// inside at the strip's mid line (even-odd rule).
Layout read_layout(const std::string& path, int strips_per_disc = 96, double max_polygon_strip_mm = 0.005);
Layout parse_layout(const nlohmann::json& j, int strips_per_disc = 96, double max_polygon_strip_mm = 0.005);
std::vector<RectMm> disc_strips(Vec2 center_mm, double radius_mm, int strips);
std::vector<RectMm> polygon_strips(const std::vector<Vec2>& vertices_mm, double max_strip_mm);

// ---- the blurred pattern (blurred_pattern.cpp) -----------------------------

// (G_sigma * indicator of a union of disjoint rectangles)(x, y), and its
// gradient, evaluated analytically. Shapes are culled through a uniform grid:
// a rectangle more than cutoff_sigmas * sigma_mm away from a point
// contributes 0, and a point that deep inside it gets exactly 1.
class BlurredPattern {
 public:
  BlurredPattern(std::vector<RectMm> rects_mm, double sigma_mm, double cutoff_sigmas = 7.0);
  double coverage(double x_mm, double y_mm) const;             // in [0, 1]
  Vec2 coverage_gradient_per_mm(double x_mm, double y_mm) const;  // d/dx, d/dy
  double sigma_mm() const { return sigma_mm_; }

 private:
  const std::vector<int>* cell_of(double x_mm, double y_mm) const;
  std::vector<RectMm> rects_mm_;
  double sigma_mm_;
  double cutoff_mm_;
  double cell_mm_;
  double origin_x_mm_ = 0, origin_y_mm_ = 0;
  int cells_x_ = 0, cells_y_ = 0;
  std::vector<std::vector<int>> cells_;
};

// One rectangle, blurred: the product of two erf differences.
double blurred_rect(const RectMm& r, double sigma_mm, double x_mm, double y_mm);
Vec2 blurred_rect_gradient_per_mm(const RectMm& r, double sigma_mm, double x_mm, double y_mm);

// ---- camera and pose (camera_pose.cpp) --------------------------------------

struct Pose {
  double distance_mm = 26;        // target centre to camera centre, along the optical axis
  double roll_deg = 0;            // about the optical axis
  double tilt_deg = 0;            // about the target's x axis through its centre
  bool mirrored = false;          // seen from the target's +z side, through the gel
  Vec2 shift_mm = {0, 0};         // the target centre moved off the axis (camera x, y)
};

struct RigidTransform {
  Mat3 rotation{};
  Vec3 translation_mm{};
  Vec3 apply(const Vec3& p) const;
};

// camera_from_target: p_cam = Rz(roll) * V * Rx(tilt) * (p - centre) + (shift, distance),
// V = identity for a direct view and a 180 degree turn about y (diag(-1, 1, -1))
// for a mirrored one: both proper rotations.
RigidTransform camera_from_target(const Pose& pose, double target_width_mm, double target_height_mm);
Vec3 rodrigues_of(const Mat3& rotation);  // the rotation vector (rad), for the truth file

class Camera {
 public:
  static Camera pinhole(int width_px, int height_px, double fx_px, double fy_px, double cx_px, double cy_px);
  static Camera from_file(const std::string& cameramodel_path);
  int width_px() const { return width_px_; }
  int height_px() const { return height_px_; }
  const std::string& lensmodel_name() const { return lensmodel_name_; }
  const std::vector<double>& intrinsics() const { return intrinsics_; }
  // Ray directions (camera frame, any length) of the pixel centres of a row.
  void unproject_row(int row, std::vector<Vec3>& rays) const;
  Vec2 project(const Vec3& p_cam_mm) const;
  // A plain-text .cameramodel (identity extrinsics) that mrcal and tactres read.
  void write_cameramodel(const std::string& path) const;

 private:
  mrcal_lensmodel_t lensmodel_{};
  std::string lensmodel_name_;
  std::vector<double> intrinsics_;
  int width_px_ = 0, height_px_ = 0;
};

// Where the ray from the camera centre along ray_cam meets the target plane
// z = 0, in target mm; false when it does not (parallel, or behind the camera).
bool intersect_target_plane(const RigidTransform& camera_from_target, const Vec3& ray_cam, Vec2& xy_mm);

// Pixels per mm of the target, at p_mm along the unit target-plane direction dir.
double px_per_mm_along(const Camera& camera, const RigidTransform& camera_from_target, Vec2 p_mm, Vec2 dir);

// ---- rendering and files (render.cpp) ---------------------------------------

struct Scene {
  std::string mode = "albedo";       // "albedo" or "relief"
  double sigma_mm = 0.1;             // Gaussian blur in the target plane
  double ink_albedo = 0.05;          // albedo mode
  double ground_albedo = 0.85;
  bool light_bars_on_dark = false;   // swaps ink and ground albedo
  double relief_mm = -1;             // relief mode; < 0: the layout's relief_height_mm
  double light_azimuth_deg = 35;     // l = (cos, sin) of this, in the target plane
  double level = 0.5;                // k0
  double gain_per_slope = 0.3;       // k1: image units per unit surface slope
  double snr_db = 0;                 // 0: no noise; else 20 log10(level step / noise sigma)
  std::uint64_t seed = 1;
};

struct Image {
  int width_px = 0, height_px = 0;
  std::vector<float> values;  // linear, row-major
  float& at(int x, int y) { return values[static_cast<size_t>(y) * width_px + x]; }
  float at(int x, int y) const { return values[static_cast<size_t>(y) * width_px + x]; }
};

// The noise-free image, point-sampled at pixel centres, on all cores.
Image render_image(const Layout& layout, const Camera& camera, const Pose& pose, const Scene& scene);
// The patch level step that the SNR refers to: |ground - ink| for albedo; for
// relief the peak shading excursion at a straight patch edge facing the light,
// gain_per_slope * relief_mm / (sqrt(2 pi) sigma_mm).
double level_step(const Layout& layout, const Scene& scene);
double noise_sigma(const Layout& layout, const Scene& scene);  // 0 without noise
void add_gaussian_noise(Image& image, double sigma, std::uint64_t seed);

// "png16", "png8" (integers scaled to full range, clipped to [0, 1], no colour
// chunk) or "tiff32f" (float, values as they are). Format from the extension
// when empty: .png -> png16, .tif/.tiff -> tiff32f.
void write_image(const std::string& path, const Image& image, std::string format = "");

// ---- truth (truth.cpp) ------------------------------------------------------

double m_true(double sigma_mm, double lp_per_mm);                   // exp(-2 pi^2 sigma^2 f^2)
double interpolated_limit_lp_per_mm(double sigma_mm, double threshold);  // where m_true = threshold

struct TruthElement {
  int group = 0, element = 0;
  std::string orientation;
  double lp_per_mm = 0;
  double m = 0;
  double px_per_bar = 0;
  double px_per_bar_along = 0;  // the bar width measured in pixels along the bars' length
  Vec2 center_px{};
  bool in_view = false;
};

struct TruthLimit {
  bool resolved_any = false;
  int group = 0, element = 0;
  double lp_per_mm = 0;                 // discrete limit
  double interpolated_lp_per_mm = 0;
  bool beyond_finest = false;
};

struct Truth {
  double sigma_mm = 0;
  double threshold = 0.1;
  std::vector<TruthElement> elements;
  TruthLimit horizontal_bars, vertical_bars;
  const TruthLimit& limit(const std::string& orientation) const {
    return orientation == "horizontal_bars" ? horizontal_bars : vertical_bars;
  }
  const TruthElement* find(int group, int element, const std::string& orientation) const;
};

Truth make_truth(const Layout& layout, const Camera& camera, const Pose& pose, double sigma_mm,
                 double threshold = 0.1);
// The true detectability limit of an albedo capture with constant Gaussian
// noise, written here from docs/CONVENTIONS.md ("Two limits") alone: each
// element's CNR = (4 / pi) m |level step| sqrt(N) / noise_sigma with N = 5
// px_per_bar px_per_bar_along (a bar is 5 widths long); the finest element
// of the chain of CNR >= k, and where CNR crosses k between it and the next
// one, ln CNR linear in f^2. 0 when nothing is detectable or everything is.
double detectability_limit_lp_per_mm(const Truth& truth, const std::string& orientation, double level_step,
                                     double noise_sigma, double k);

nlohmann::json truth_json(const Truth& truth, const Pose& pose, const Scene& scene, const Camera& camera,
                          const Layout& layout);

// ---- a case file, for the reference_render CLI (case_file.cpp) -------------

struct RenderCase {
  std::string layout_path;
  std::string camera_path;      // a .cameramodel, or empty for the pinhole below
  std::array<double, 4> pinhole_fxfycxcy{560, 560, 639.5, 359.5};
  std::array<int, 2> pinhole_size_px{1280, 720};
  Pose pose;
  Scene scene;
  std::string image_path;
  std::string format;           // see write_image
  std::string truth_path;       // default: image_path + ".truth.json"
};

// Paths in the file are relative to the file's folder.
RenderCase read_case(const std::string& case_path);
// Renders the case, writes the image and the truth file, returns the truth.
Truth run_case(const RenderCase& c);

}  // namespace reference
