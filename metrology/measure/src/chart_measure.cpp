#include "tactres/measure/chart_measure.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <tuple>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "tactres/util/stopwatch.h"
#include "tactres/measure/element_grading.h"
#include "tactres/profiles/profile_sampler.h"
#include "tactres/camera/target_view.h"
#include "tactres/targets/coverage.h"
#include "tactres/targets/usaf_series.h"

namespace tactres {

void ChartMeasureOptions::validate() const {
  measure.validate();
  detect.validate();
}

namespace {


Vec2 perp(Vec2 d) { return {-d.y, d.x}; }

// A pattern's frame: image = centre + px_per_mm * (x ex + y ey), with the
// pattern centred on the local target origin. ey = perp(ex) keeps it a
// proper rotation; whether the chart is mirrored does not matter locally.
struct LocalFrame {
  Vec2 center_px;
  Vec2 ex;  // image direction of local x
  double px_per_mm = 1;
  Vec2 to_local(Vec2 q) const {
    const Vec2 d = q - center_px;
    return (1.0 / px_per_mm) * Vec2{dot(d, ex), dot(d, perp(ex))};
  }
};

// The pinhole camera and pose that realise a LocalFrame, so that the shared
// profile sampler maps pixels to the local target plane.
constexpr double kFocalPx = 1000.0;
std::array<double, 6> rt_of(const LocalFrame& f) {
  const double z = kFocalPx / f.px_per_mm;
  return {0, 0, std::atan2(f.ex.y, f.ex.x), f.center_px.x * z / kFocalPx, f.center_px.y * z / kFocalPx, z};
}

struct PatternRef {
  int pattern;
  BarOrientation orientation;
  int group, element;
  double lp_per_mm;
};

// Frame of pattern P measured as orientation O (local x along the bars of
// an H pattern, across the bars of a V pattern).
LocalFrame frame_of(const BarPattern& p, BarOrientation o, double lp_per_mm) {
  LocalFrame f;
  f.center_px = p.center_px;
  f.ex = o == BarOrientation::horizontal_bars ? p.bar_dir : perp(p.bar_dir);
  f.px_per_mm = p.period_px * lp_per_mm;
  return f;
}

// The local layout: this pattern as an element, and the bars of every
// detected pattern near it as artwork (approximated as axis-aligned in the
// local frame; they are neighbours, not the measured bars).
TargetLayout local_layout(const ChartDetection& D, const PatternRef& r, const LocalFrame& f) {
  TargetLayout L;
  const double w = 0.5 / r.lp_per_mm;
  ElementLayout e;
  e.group = r.group;
  e.element = r.element;
  e.lp_per_mm = r.lp_per_mm;
  e.bar_width_mm = w;
  e.orientation = r.orientation;
  for (int i = 0; i < 3; ++i) {
    const double c = (i - 1) * 2 * w;
    e.bars_mm[i] = r.orientation == BarOrientation::horizontal_bars ? RectMm{-2.5 * w, c - 0.5 * w, 2.5 * w, c + 0.5 * w}
                                                                     : RectMm{c - 0.5 * w, -2.5 * w, c + 0.5 * w, 2.5 * w};
    L.artwork.push_back({ArtworkShape::Kind::rect, ArtworkShape::Role::bar, e.bars_mm[i], {}, 0, {}});
  }
  L.elements.push_back(e);
  const RectMm own = e.extent_mm().inflated(0.25 * w);
  const BarPattern& self = D.patterns[r.pattern];
  for (size_t k = 0; k < D.patterns.size(); ++k) {
    if (static_cast<int>(k) == r.pattern) continue;
    const BarPattern& q = D.patterns[k];
    if (norm(q.center_px - self.center_px) > 12 * self.period_px + 3 * q.bar_length_px) continue;
    const Vec2 n = perp(q.bar_dir);
    const double qw = 0.5 * q.period_px / f.px_per_mm, ql = 5 * qw;
    const bool along_x = std::abs(dot(q.bar_dir, f.ex)) > std::sqrt(0.5);
    for (int i = -1; i <= 1; ++i) {
      const Vec2 c = f.to_local(q.center_px + (i * q.period_px) * n);
      const RectMm b = along_x ? RectMm{c.x - 0.5 * ql, c.y - 0.5 * qw, c.x + 0.5 * ql, c.y + 0.5 * qw}
                               : RectMm{c.x - 0.5 * qw, c.y - 0.5 * ql, c.x + 0.5 * qw, c.y + 0.5 * ql};
      if (b.overlap_area_mm2(own) > 0) continue;  // a mis-detection on top of ours: not modelled
      L.artwork.push_back({ArtworkShape::Kind::rect, ArtworkShape::Role::bar, b, {}, 0, {}});
    }
  }
  RectMm ext{1e300, 1e300, -1e300, -1e300};
  for (const ArtworkShape& s : L.artwork) ext = bounding_union(ext, s.bounds_mm());
  L.width_mm = ext.x1;
  L.height_mm = ext.y1;
  L.first_group = L.last_group = r.group;
  return L;
}

// Shift (mm, along u) of the pattern that best matches the data: the mean
// level in narrow windows at the bar centres against that at the gap
// centres, on the detrended profile. Blur is symmetric, so it does not move
// the optimum; the scale is left to the profile fit (fit_scale), because
// any such template is biased in scale by the blur of a finite pattern.
double refine_shift(const ProfileData& d, double w, bool light) {
  double s0 = 0, s1 = 0, s2 = 0, t0 = 0, t1 = 0;
  for (int b = d.fit_begin; b < d.fit_end; ++b)
    if (d.count[b] > 0) {
      const double u = d.u_mean_mm[b], v = d.value[b];
      s0 += 1, s1 += u, s2 += u * u, t0 += v, t1 += u * v;
    }
  const double det = s0 * s2 - s1 * s1;
  if (s0 < 8 || !(std::abs(det) > 0)) return 0;
  const double slope = (s0 * t1 - s1 * t0) / det, icpt = (t0 - slope * s1) / s0;
  auto score = [&](double shift) {
    double bar = 0, gap = 0;
    int nb = 0, ng = 0;
    for (int b = d.fit_begin; b < d.fit_end; ++b) {
      if (d.count[b] == 0) continue;
      const double u = d.u_mean_mm[b] - shift;
      const double r = d.value[b] - (icpt + slope * d.u_mean_mm[b]);
      for (int k = -3; k <= 3; ++k) {
        if (std::abs(u - k * w) >= 0.25 * w) continue;
        if (k % 2 == 0) bar += r, ++nb;
        else gap += r, ++ng;
      }
    }
    if (nb == 0 || ng == 0) return -1e300;
    const double c = bar / nb - gap / ng;
    return light ? c : -c;
  };
  double best_shift = 0, best = -1e300;
  const double h = 0.05 * w;
  for (int i = -12; i <= 12; ++i) {
    const double v = score(i * h);
    if (v > best) best = v, best_shift = i * h;
  }
  const double fm = score(best_shift - h), fp = score(best_shift + h), den = fm - 2 * best + fp;
  if (den < 0) best_shift += h * std::clamp(0.5 * (fm - fp) / den, -0.5, 0.5);
  return best_shift;
}

// Negative charts: the ideal pattern is the complement, 1 - S(u). The
// constant is a box over exactly the model's grid: the model evaluates the
// pattern's spectrum on that (periodic) grid, where such a box is a pure
// constant, and a wider one would not be 1.
bool is_complement_box(const ProfileData& d, const IdealBox& b) {
  return b.level == 1.0 && b.u0_mm <= d.u0_mm && b.u1_mm >= d.u0_mm + d.bin_count * d.bin_mm;
}

void complement(ProfileData& d) {
  for (IdealBox& b : d.ideal) b.level = -b.level;
  d.ideal.push_back({d.u0_mm, d.u0_mm + d.bin_count * d.bin_mm, 1.0});
}

// The profile's ideal pattern stretched by `scale` about the pattern centre
// (the complement's constant stays as it is).
ProfileData scaled(const ProfileData& d, double scale) {
  ProfileData out = d;
  for (IdealBox& b : out.ideal)
    if (!is_complement_box(d, b)) b.u0_mm *= scale, b.u1_mm *= scale;
  return out;
}

// The ideal pattern moved by `shift_mm` along u (the complement's constant
// stays).
ProfileData shifted(const ProfileData& d, double shift_mm) {
  ProfileData out = d;
  for (IdealBox& b : out.ideal)
    if (!is_complement_box(d, b)) b.u0_mm += shift_mm, b.u1_mm += shift_mm;
  return out;
}

// The shift the profile model itself prefers, to a small fraction of a
// bar: the vertex of chi^2 over three shifted ideals, twice, with the step
// shrinking. The correlation centring (refine_shift) gets within a tenth of
// a bar or so; at sharp edges and near the limit that residue would still
// read as blur. Returns the profile with the ideal moved.
ProfileData refine_shift_by_fit(const ProfileData& d, const ProfileFitOptions& fo, double w_mm) {
  ProfileData best = d;
  double h = 0.1 * w_mm;
  for (int iter = 0; iter < 2; ++iter, h /= 3) {
    double chi[3];
    for (int i = 0; i < 3; ++i) {
      const ProfileFit f = fit_profile(shifted(best, (i - 1) * h), fo);
      if (!f.usable) return best;
      chi[i] = f.chi2_reduced;
    }
    const double den = chi[0] - 2 * chi[1] + chi[2];
    // No curvature worth the name: the data do not place the pattern.
    if (!(den > 1e-3 * chi[1])) return best;
    best = shifted(best, h * std::clamp(0.5 * (chi[0] - chi[2]) / den, -1.5, 1.5));
  }
  return best;
}

// The scale of the pattern (relative to the frame's) that the profile model
// itself prefers: the vertex of chi^2 over three stretched ideals. Only
// well-sampled, well-modulated patterns pin it down; nullopt otherwise.
std::optional<double> fit_scale(const ProfileData& d, const ProfileFitOptions& fo) {
  constexpr double h = 0.03;
  double chi[3];
  for (int i = 0; i < 3; ++i) {
    const ProfileFit f = fit_profile(scaled(d, 1 + (i - 1) * h), fo);
    if (!f.usable) return std::nullopt;
    chi[i] = f.chi2_reduced;
  }
  const double den = chi[0] - 2 * chi[1] + chi[2];
  if (!(den > 0)) return std::nullopt;
  const double x = 0.5 * (chi[0] - chi[2]) / den;
  if (std::abs(x) > 2) return std::nullopt;
  return 1 + x * h;
}

class PatternSampler {
 public:
  PatternSampler(const cv::Mat& lum, const ChartDetection& D, double clip_level, int width, int height)
      : lum_(lum), D_(D), clip_(clip_level), cam_(CameraModel::pinhole(kFocalPx, kFocalPx, 0, 0, width, height)) {}

  // The strip of `r` seen through frame `f`; the ideal is complemented for
  // negative charts.
  SampledProfile sample(const PatternRef& r, const LocalFrame& f, const ProfileSamplingOptions& so) const {
    const TargetLayout layout = local_layout(D_, r, f);
    const TargetView view(cam_, rt_of(f));
    const ArtworkIndex index(layout.artwork, 0.0);
    SampledProfile p = sample_strip(lum_, view, layout, index, element_strip(layout.elements.front(), so), so, clip_);
    if (D_.light_bars && p.in_view) complement(p.data);
    return p;
  }

  // Moves the frame's centre onto the pattern (across the bars).
  LocalFrame recentre(const PatternRef& r, LocalFrame f, const ProfileSamplingOptions& so) const {
    // A predicted pattern is placed by its column, more precisely than its
    // faint bars could place it.
    if (D_.patterns[r.pattern].predicted) return f;
    const SampledProfile p = sample(r, f, so);
    if (!p.in_view) return f;
    const double shift_mm = refine_shift(p.data, 0.5 / r.lp_per_mm, D_.light_bars);
    const Vec2 u_dir = r.orientation == BarOrientation::vertical_bars ? f.ex : perp(f.ex);
    f.center_px = f.center_px + (shift_mm * f.px_per_mm) * u_dir;
    return f;
  }

 private:
  const cv::Mat& lum_;
  const ChartDetection& D_;
  double clip_;
  CameraModel cam_;
};

// Image scale across the bars over the chart, per orientation:
// ln(px/mm) = c0 + c1 x + c2 y (pixels), fitted to the patterns whose scale
// the profile model pinned down. A plane seen in mild perspective has a
// smoothly varying scale, and the coarse patterns fix it far better than a
// fine pattern near the limit can fix its own.
struct ScaleField {
  bool valid = false;
  double c[3] = {0, 0, 0};
  double at(Vec2 p) const { return std::exp(c[0] + c[1] * p.x + c[2] * p.y); }
};

ScaleField fit_scale_field(const std::vector<std::pair<Vec2, double>>& samples) {
  ScaleField f;
  if (samples.empty()) return f;
  double mean = 0;
  for (const auto& s : samples) mean += std::log(s.second);
  mean /= samples.size();
  f.c[0] = mean;
  f.valid = true;
  if (samples.size() < 4) return f;  // too few for a gradient: constant
  cv::Mat A(static_cast<int>(samples.size()), 3, CV_64F), b(static_cast<int>(samples.size()), 1, CV_64F);
  for (size_t i = 0; i < samples.size(); ++i) {
    A.at<double>(int(i), 0) = 1;
    A.at<double>(int(i), 1) = samples[i].first.x;
    A.at<double>(int(i), 2) = samples[i].first.y;
    b.at<double>(int(i)) = std::log(samples[i].second);
  }
  cv::Mat x;
  if (!cv::solve(A, b, x, cv::DECOMP_SVD)) return f;
  for (int k = 0; k < 3; ++k) f.c[k] = x.at<double>(k);
  return f;
}

}  // namespace

ChartMeasurement measure_chart(const LoadedImage& image, const ChartMeasureOptions& options) {
  options.validate();
  const MeasureOptions& mo = options.measure;
  ChartMeasurement out;
  Measurement& M = out.measurement;
  M.image_width = image.width;
  M.image_height = image.height;
  M.camera_source = "none: chart mode, each pattern in its own frame from the detection";
  M.distortion_corrected = false;
  M.transfer = image.transfer;
  const cv::Mat& lum = image.luminance;

  Stopwatch t;
  out.detection = detect_chart(lum, options.detect);
  const ChartDetection& D = out.detection;
  M.stage_seconds.push_back({"detect_chart", t.seconds()});
  if (!D.found) {
    M.problem = D.problem;
    return out;
  }

  std::vector<PatternRef> refs;
  for (const ChartElement& e : D.elements) {
    const double f = usaf_lp_per_mm(e.group, e.element);
    refs.push_back({e.h, BarOrientation::horizontal_bars, e.group, e.element, f});
    refs.push_back({e.v, BarOrientation::vertical_bars, e.group, e.element, f});
  }
  const PatternSampler sampler(lum, D, image.saturation_level, image.width, image.height);
  auto sampling_for = [&](double px_per_bar) {
    ProfileSamplingOptions so = mo.sampling;
    so.bin_px = std::max(so.bin_px, px_per_bar / mo.max_bins_per_bar);
    return so;
  };

  // Frames: centred on each pattern, then the scale from the profile model
  // on the coarse patterns, smoothed over the chart.
  t.restart();
  std::vector<LocalFrame> frames;
  std::vector<std::pair<Vec2, double>> scale_samples[2];  // [across_x]
  for (const PatternRef& r : refs) {
    const double px_per_bar = 0.5 * D.patterns[r.pattern].period_px;
    const ProfileSamplingOptions so = sampling_for(px_per_bar);
    LocalFrame f = sampler.recentre(r, frame_of(D.patterns[r.pattern], r.orientation, r.lp_per_mm), so);
    frames.push_back(f);
    if (px_per_bar < 4) continue;
    const SampledProfile p = sampler.sample(r, f, so);
    if (!p.in_view) continue;
    ProfileFitOptions fo;
    fo.fit_contrast = true;
    fo.fit_shape = false;
    if (const auto a = fit_scale(p.data, fo))
      scale_samples[r.orientation == BarOrientation::vertical_bars].push_back({f.center_px, f.px_per_mm * *a});
  }
  ScaleField field[2] = {fit_scale_field(scale_samples[0]), fit_scale_field(scale_samples[1])};
  if (!field[0].valid) field[0] = field[1];
  if (!field[1].valid) field[1] = field[0];
  std::vector<SampledProfile> profiles;
  // The strip at the detected centre, where the correlation centring moved
  // the frame by more than a tenth of a bar: on faint, barely sampled
  // patterns (~3 px per bar, m ~ 0.1) the correlation can lock half a bar
  // off while the binarised bars' centroid was right, and a misplaced
  // pattern reads as blur. The grading keeps whichever the profile model
  // fits better.
  std::vector<std::optional<SampledProfile>> at_detected(refs.size());
  for (size_t i = 0; i < refs.size(); ++i) {
    const PatternRef& r = refs[i];
    LocalFrame& f = frames[i];
    const bool across_x = r.orientation == BarOrientation::vertical_bars;
    if (field[across_x].valid) f.px_per_mm = field[across_x].at(f.center_px);
    const double px_per_bar = 0.5 / r.lp_per_mm * f.px_per_mm;
    const ProfileSamplingOptions so = sampling_for(px_per_bar);
    f = sampler.recentre(r, f, so);
    profiles.push_back(sampler.sample(r, f, so));
    LocalFrame detected = f;
    detected.center_px = D.patterns[r.pattern].center_px;
    if (!D.patterns[r.pattern].predicted && norm(detected.center_px - f.center_px) > 0.1 * px_per_bar)
      at_detected[i] = sampler.sample(r, detected, so);
  }
  M.stage_seconds.push_back({"frames", t.seconds()});

  // Contrast scale per direction: the median of the three coarsest
  // elements that allow it, so that one odd pattern (a mismatch, dust on a
  // bar) does not scale every other.
  t.restart();
  ReferenceResult& ref = M.reference;
  ref.signature = Signature::albedo;
  std::vector<ProfileFit> contrast_fits[2];  // [across_x]
  for (size_t i = 0; i < refs.size(); ++i) {
    const PatternRef& r = refs[i];
    const bool across_x = r.orientation == BarOrientation::vertical_bars;
    const SampledProfile& p = profiles[i];
    if (contrast_fits[across_x].size() >= 3 || 0.5 / r.lp_per_mm * frames[i].px_per_mm < 3) continue;
    if (D.patterns[r.pattern].predicted || !p.in_view || p.pixels_clipped > p.pixels_used / 50) continue;
    ProfileFitOptions fo;
    fo.fit_contrast = true;
    fo.fit_shape = mo.fit_psf_shape;  // a fixed Gaussian would put a heavy-tailed PSF's low-frequency loss into the level step
    const ProfileFit fit = fit_profile(p.data, fo);
    if (fit.usable && std::abs(fit.contrast) > 5 * fit.contrast_sigma) contrast_fits[across_x].push_back(fit);
  }
  bool have[2] = {false, false};
  for (int ax = 0; ax < 2; ++ax) {
    std::vector<ProfileFit>& f = contrast_fits[ax];
    if (f.empty()) continue;
    std::sort(f.begin(), f.end(), [](const ProfileFit& a, const ProfileFit& b) { return a.contrast < b.contrast; });
    const ProfileFit& med = f[f.size() / 2];
    (ax ? ref.contrast_x : ref.contrast_y) = med.contrast;
    (ax ? ref.contrast_x_sigma : ref.contrast_y_sigma) = med.contrast_sigma;
    (ax ? ref.chi2_x : ref.chi2_y) = med.chi2_reduced;
    have[ax] = true;
  }
  M.stage_seconds.push_back({"reference_patch", t.seconds()});
  if (!have[0] && !have[1]) {
    M.problem =
        "the chart's level step cannot be measured: no element in full view has 3 or more pixels per bar with "
        "visible bars; frame a coarser group or bring the chart into focus";
    return out;
  }
  // One direction missing: the other's level step stands in (a printed
  // chart has one ink density).
  if (!have[0]) ref.contrast_y = ref.contrast_x, ref.contrast_y_sigma = ref.contrast_x_sigma;
  if (!have[1]) ref.contrast_x = ref.contrast_y, ref.contrast_x_sigma = ref.contrast_y_sigma;
  ref.usable = true;

  // Nyquist at the chart plane, from the largest element's scale.
  M.nyquist_h_lp_per_mm = 0.5 * frames[0].px_per_mm;
  M.nyquist_v_lp_per_mm = 0.5 * frames[1].px_per_mm;

  // Every pattern, graded as in layout mode (measure.cpp).
  double fit_s = 0;
  std::pair<double, double> last_lsf[2] = {{0, 0}, {0, 0}};
  for (size_t i = 0; i < refs.size(); ++i) {
    const PatternRef& r = refs[i];
    const SampledProfile& sp = profiles[i];
    ElementResult e;
    e.group = r.group;
    e.element = r.element;
    e.orientation = r.orientation;
    e.lp_per_mm = r.lp_per_mm;
    const bool across_x = r.orientation == BarOrientation::vertical_bars;
    e.px_per_bar = 0.5 / r.lp_per_mm * frames[i].px_per_mm;
    ProfileFitOptions fo;
    fo.signature = Signature::albedo;
    fo.contrast = across_x ? ref.contrast_x : ref.contrast_y;
    fo.fit_shape = mo.fit_psf_shape;
    ProfilePrepare centre;
    // A predicted pattern is placed by its column, more precisely than its
    // faint bars could place it.
    if (!D.patterns[r.pattern].predicted)
      centre = [w = 0.5 / r.lp_per_mm](const ProfileData& d, const ProfileFitOptions& o) {
        return refine_shift_by_fit(d, o, w);
      };
    const double contrast_sigma = across_x ? ref.contrast_x_sigma : ref.contrast_y_sigma;
    const std::pair<double, double> warm = last_lsf[across_x];
    fit_s += grade_element(e, sp, fo, contrast_sigma, mo, last_lsf[across_x], centre);
    if (at_detected[i] && at_detected[i]->in_view) {
      ElementResult alt = e;
      alt.m = alt.m_sigma = alt.beta = alt.chi2_reduced = 0;
      std::pair<double, double> alt_warm = warm;
      fit_s += grade_element(alt, *at_detected[i], fo, contrast_sigma, mo, alt_warm, centre);
      const bool e_fit = e.chi2_reduced > 0, alt_fit = alt.chi2_reduced > 0;
      if (alt_fit && (!e_fit || alt.chi2_reduced < e.chi2_reduced)) {
        e = alt;
        last_lsf[across_x] = alt_warm;
      }
    }
    M.elements.push_back(e);
  }
  M.stage_seconds.push_back({"fits", fit_s});

  t.restart();
  // The limit runs over the elements in view: a chart photograph frames
  // some groups and cuts others, and a cut coarse element says nothing
  // about the finer ones (layout mode, which frames the whole target,
  // counts it as unresolved instead).
  decide_limits(M, mo.criterion, true);
  // Partial elements: a status, not a guess (ChartElement::partial). They
  // were not measured, so they take no part in the limits (added after the
  // decision) and are never resolved.
  for (const ChartElement& ce : D.partial) {
    for (BarOrientation o : {BarOrientation::horizontal_bars, BarOrientation::vertical_bars}) {
      ElementResult e;
      e.group = ce.group;
      e.element = ce.element;
      e.orientation = o;
      e.lp_per_mm = usaf_lp_per_mm(ce.group, ce.element);
      e.px_per_bar = 0.5 * ce.period_px;
      e.status = ce.partial == ChartElement::Partial::partner_out_of_view ? ElementStatus::out_of_view
                                                                          : ElementStatus::fit_failed;
      M.elements.push_back(e);
    }
  }
  std::stable_sort(M.elements.begin(), M.elements.end(), [](const ElementResult& a, const ElementResult& b) {
    return std::tuple(a.group, a.element) < std::tuple(b.group, b.element);
  });
  M.stage_seconds.push_back({"decide", t.seconds()});
  M.usable = true;
  return out;
}

nlohmann::json chart_to_json(const ChartDetection& d) {
  nlohmann::json j;
  j["mode"] = "usaf1951";
  j["found"] = d.found;
  j["polarity"] = d.light_bars ? "light_bars_on_dark" : "dark_bars_on_light";
  j["anchor"] = to_string(d.anchor);
  j["anchor_description"] = d.anchor_description;
  j["indices"] = d.anchor == ChartAnchor::none ? "relative" : "absolute";
  j["patterns_found"] = d.patterns.size();
  j["elements_found"] = d.elements.size();
  j["unpaired_patterns"] = d.unpaired_patterns;
  j["predicted_elements"] = d.predicted_elements;
  const auto& a = d.arrangement;
  if (a.steps_checked > 0 || !a.note.empty())
    j["arrangement"] = {{"recognised", a.recognised},
                        {"mirrored", a.recognised ? nlohmann::json(a.mirrored) : nlohmann::json()},
                        {"steps_checked", a.steps_checked},
                        {"steps_matched", a.steps_matched},
                        {"group_labels_read", a.labels_read},
                        {"note", a.note}};
  j["partial_elements"] = nlohmann::json::array();
  for (const ChartElement& e : d.partial)
    j["partial_elements"].push_back(
          {{"group", e.group},
           {"element", e.element},
           {"found", e.h >= 0 ? "horizontal_bars" : "vertical_bars"},
           {"status", e.partial == ChartElement::Partial::partner_out_of_view ? "out_of_view" : "fit_failed"},
           {"reason", e.partial_reason}});
  if (!d.elements.empty()) {
    const ChartElement& e = d.elements.front();
    j["largest_element"] = {{"group", e.group}, {"element", e.element}, {"period_px", e.period_px}};
  }
  return j;
}

}  // namespace tactres
