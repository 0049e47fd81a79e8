#include "chart_frames.h"

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>

namespace tactres::chart {

namespace {

Vec2 perp(Vec2 d) { return {-d.y, d.x}; }

// The element that pattern `r` is: three bars of width w, 5 w long, about
// the plane's origin.
ElementLayout local_element(const PatternRef& r) {
  const double w = r.bar_width_mm();
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
  }
  return e;
}

// The ideal artwork of pattern `r`'s plane: its own bars, and the bars of
// every detected pattern near it (approximated as axis-aligned in the
// plane; they are neighbours, not the measured bars).
std::vector<ArtworkShape> local_artwork(const ChartDetection& D, const PatternRef& r, const ElementLayout& e,
                                        const PatternFrame& f) {
  std::vector<ArtworkShape> shapes;
  for (const RectMm& bar : e.bars_mm) shapes.push_back({ArtworkShape::Kind::rect, ArtworkShape::Role::bar, bar, {}, 0, {}});
  const double w = e.bar_width_mm;
  const RectMm own = e.extent_mm().inflated(0.25 * w);
  const BarPattern& self = D.patterns[r.pattern];
  for (size_t k = 0; k < D.patterns.size(); ++k) {
    if (static_cast<int>(k) == r.pattern) continue;
    const BarPattern& q = D.patterns[k];
    if (norm(q.center_px - self.center_px) > 12 * self.period_px + 3 * q.bar_length_px) continue;
    const Vec2 n = perp(q.bar_dir);
    const double qw = 0.5 * q.period_px / f.px_per_mm, ql = 5 * qw;
    const bool along_plane_x = std::abs(dot(q.bar_dir, f.x_dir)) > std::sqrt(0.5);
    for (int i = -1; i <= 1; ++i) {
      const Vec2 c = f.to_plane(q.center_px + (i * q.period_px) * n);
      const RectMm b = along_plane_x ? RectMm{c.x - 0.5 * ql, c.y - 0.5 * qw, c.x + 0.5 * ql, c.y + 0.5 * qw}
                                     : RectMm{c.x - 0.5 * qw, c.y - 0.5 * ql, c.x + 0.5 * qw, c.y + 0.5 * ql};
      if (b.overlap_area_mm2(own) > 0) continue;  // a mis-detection on top of ours: not modelled
      shapes.push_back({ArtworkShape::Kind::rect, ArtworkShape::Role::bar, b, {}, 0, {}});
    }
  }
  return shapes;
}

// The detrended profile of a pattern: its filled bins' positions and their
// departures from the straight line through them (light falling off
// across a strip would otherwise favour one side), with the bins'
// standard errors.
struct Detrended {
  std::vector<double> u_mm, r, sigma;
  double rms = 0;
};

Detrended detrended(const ProfileData& d) {
  Detrended out;
  double s0 = 0, s1 = 0, s2 = 0, t0 = 0, t1 = 0;
  for (int b = d.fit_begin; b < d.fit_end; ++b)
    if (d.count[b] > 0) {
      const double u = d.u_mean_mm[b], v = d.value[b];
      s0 += 1, s1 += u, s2 += u * u, t0 += v, t1 += u * v;
    }
  const double det = s0 * s2 - s1 * s1;
  if (s0 < 8 || !(std::abs(det) > 0)) return out;
  const double slope = (s0 * t1 - s1 * t0) / det, icpt = (t0 - slope * s1) / s0;
  double ss = 0;
  for (int b = d.fit_begin; b < d.fit_end; ++b)
    if (d.count[b] > 0) {
      out.u_mm.push_back(d.u_mean_mm[b]);
      out.r.push_back(d.value[b] - (icpt + slope * d.u_mean_mm[b]));
      out.sigma.push_back(d.sigma[b]);
      ss += out.r.back() * out.r.back();
    }
  out.rms = std::sqrt(ss / static_cast<double>(out.r.size()));
  return out;
}

// The mean level in narrow windows (half a bar) at the bar centres k w, k
// even, against that at the gap centres, k odd, for |k| <= k_max, with the
// pattern moved by `shift_mm`; signed so that a match is positive.
struct WindowContrast {
  double contrast = -1e300;  // -1e300: no bin in the bar windows or none in the gap windows
  double sigma = 0;          // its standard error, from the bins' (ProfileData::sigma)
};

WindowContrast bar_gap_contrast(const Detrended& t, double w_mm, bool light, double shift_mm, int k_max) {
  double bar = 0, gap = 0, var_bar = 0, var_gap = 0;
  int nb = 0, ng = 0;
  for (size_t i = 0; i < t.u_mm.size(); ++i) {
    const double u = t.u_mm[i] - shift_mm;
    for (int k = -k_max; k <= k_max; ++k) {
      if (std::abs(u - k * w_mm) >= 0.25 * w_mm) continue;
      if (k % 2 == 0) bar += t.r[i], var_bar += t.sigma[i] * t.sigma[i], ++nb;
      else gap += t.r[i], var_gap += t.sigma[i] * t.sigma[i], ++ng;
    }
  }
  WindowContrast out;
  if (nb == 0 || ng == 0) return out;
  const double c = bar / nb - gap / ng;
  out.contrast = light ? c : -c;
  out.sigma = std::sqrt(var_bar / (double(nb) * nb) + var_gap / (double(ng) * ng));
  return out;
}

// Shift (mm, along u) of the pattern that best matches the data: the bar
// against gap contrast (with the ground beyond the outer bars as gaps) on
// the detrended profile. Blur is symmetric, so it does not move
// the optimum; the scale is left to the profile fit (fit_scale), because
// any such template is biased in scale by the blur of a finite pattern.
double refine_shift(const ProfileData& d, double w_mm, bool light) {
  const Detrended t = detrended(d);
  if (t.r.empty()) return 0;
  auto score = [&](double shift_mm) { return bar_gap_contrast(t, w_mm, light, shift_mm, 3).contrast; };
  double best_shift = 0, best = -1e300;
  const double h = 0.05 * w_mm;
  for (int i = -12; i <= 12; ++i) {
    const double v = score(i * h);
    if (v > best) best = v, best_shift = i * h;
  }
  const double fm = score(best_shift - h), fp = score(best_shift + h), den = fm - 2 * best + fp;
  if (den < 0) best_shift += h * std::clamp(0.5 * (fm - fp) / den, -0.5, 0.5);
  return best_shift;
}

// A triplet found one period off along its column (the binarised bars of
// two neighbours, or a bar and a shoulder of the ground: a JPEG copy of
// dev_04 took G6E3 H's lower two bars and the shoulder below them for its
// triplet) matches the triplet's windows, the ground beyond its outer bars
// counted as gaps (k_max 3), worse than the place one period along u. On a
// true triplet a period's slip trades an outer bar for ground in the bar
// windows and leaves the gap windows' sum as it was, so it scores lower,
// however blurred the bars. Clearly: by a tenth of the contrast there and
// by 3 sigma of the bins' noise.
int period_slip_of(const Detrended& t, double w_mm, bool light) {
  const WindowContrast here = bar_gap_contrast(t, w_mm, light, 0, 3);
  int best = 0;
  WindowContrast there = here;
  for (const int s : {-1, 1}) {
    const WindowContrast c = bar_gap_contrast(t, w_mm, light, 2 * s * w_mm, 3);
    if (c.contrast > there.contrast) best = s, there = c;
  }
  if (best == 0 || here.contrast <= -1e300 || !(there.contrast > 0)) return 0;
  const double gain = there.contrast - here.contrast;
  return gain >= 0.1 * there.contrast && gain >= 3 * std::hypot(there.sigma, here.sigma) ? best : 0;
}

// The profile's ideal pattern stretched by `scale` about the pattern centre
// (the complement's constant stays as it is).
ProfileData scaled(const ProfileData& d, double scale) {
  ProfileData out = d;
  for (IdealBox& b : out.ideal)
    if (!is_complement_box(d, b)) b.u0_mm *= scale, b.u1_mm *= scale;
  return out;
}

}  // namespace

std::vector<std::optional<double>> shared_shifts_px(const std::vector<ShiftSample>& samples, bool light,
                                                    double max_px) {
  const size_t n = samples.size();
  constexpr double kStepPx = 0.1;
  const int steps = static_cast<int>(max_px / kStepPx);
  const size_t trials = 2 * static_cast<size_t>(steps) + 1;  // trial t: shift (t - steps) kStepPx
  // Per sample and trial, the contrast itself (which picks the shift: the
  // patterns share the light, and one without bars adds only its noise),
  // over the profile's rms (how clearly the bars show) and over its
  // standard error (how surely). Only the triplet's own windows
  // (|k| <= 2): beyond the outer bars of a column's patterns stand its
  // neighbours.
  const std::vector<double> none(trials, 0);
  std::vector<std::vector<double>> contrast(n, none), effect(n, none), z(n, none);
  std::vector<unsigned char> usable(n, 0);
  for (size_t i = 0; i < n; ++i) {
    const Detrended t = detrended(*samples[i].data);
    if (!(t.rms > 0)) continue;
    usable[i] = 1;
    for (size_t k = 0; k < trials; ++k) {
      const double shift_px = (static_cast<int>(k) - steps) * kStepPx;
      const WindowContrast c = bar_gap_contrast(t, samples[i].bar_mm, light, shift_px * samples[i].u_mm_per_px, 2);
      if (c.contrast <= -1e300 || !(c.sigma > 0)) continue;
      contrast[i][k] = c.contrast;
      effect[i][k] = c.contrast / t.rms;
      z[i][k] = c.contrast / c.sigma;
    }
  }
  // The sum over the patterns but `except` (n: over all) at trial k.
  auto sum_but = [&](const std::vector<std::vector<double>>& per, size_t k, size_t except) {
    double total = 0;
    for (size_t j = 0; j < n; ++j)
      if (j != except && usable[j]) total += per[j][k];
    return total;
  };
  const size_t zero = static_cast<size_t>(steps);
  double count = 0;
  for (size_t j = 0; j < n; ++j) count += usable[j];
  std::vector<std::optional<double>> out(n);
  for (size_t i = 0; i < n; ++i) {
    // Where: the others' best, so that a pattern's own noise cannot place
    // it.
    size_t best = zero;
    for (size_t k = 0; k < trials; ++k)
      if (sum_but(contrast, k, i) > sum_but(contrast, best, i)) best = k;
    // Whether: the whole group there (a pattern's data at a place its own
    // noise did not choose are unbiased; the pattern best seen must agree
    // too: left out, the faint rest can line up on the next element's
    // bars, 1.5 bars along a column). Only where the bars show clearly,
    // in several patterns, and far better than where they were placed:
    // - a mean contrast of one rms or more (the groups moved on real
    //   captures reach 1.2-2.2; those left where predicted, 0.1-0.55);
    // - half an rms a pattern more than unshifted;
    // - two patterns or more that show their bars there on their own, by
    //   one rms and by 4 sigma of the bins' noise: one pattern lines up as
    //   well a period away, and noise alone, a standard normal at each
    //   trial, seldom reaches 4 sigma in two patterns at once. (On real
    //   captures the bins' noise model understates the texture: summed
    //   over a group it reads 5-14 sigma where there are no bars to line
    //   up, so the contrast over the rms decides there.)
    const double effect_there = sum_but(effect, best, n);
    int clear = 0;
    for (size_t j = 0; j < n; ++j) clear += usable[j] && effect[j][best] >= 1 && z[j][best] >= 4;
    if (effect_there < count || effect_there - sum_but(effect, zero, n) < 0.5 * count || clear < 2) continue;
    out[i] = (static_cast<int>(best) - steps) * kStepPx;
  }
  return out;
}

PatternFrame frame_of(const BarPattern& p, BarOrientation o, double lp_per_mm) {
  return {p.center_px, o == BarOrientation::horizontal_bars ? p.bar_dir : perp(p.bar_dir), p.period_px * lp_per_mm};
}

ProfileData shifted_ideal(const ProfileData& d, double shift_mm) {
  ProfileData out = d;
  for (IdealBox& b : out.ideal)
    if (!is_complement_box(d, b)) b.u0_mm += shift_mm, b.u1_mm += shift_mm;
  return out;
}

ElementPlacement PlacementStore::place(const PatternRef& r, const PatternFrame& f, const ProfileSamplingOptions& so) {
  const ElementLayout e = local_element(r);
  frames_.push_back(f);
  artworks_.push_back(std::make_shared<const IndexedArtwork>(local_artwork(D_, r, e, f), 0.0));
  return {&frames_.back(), artworks_.back().get(), element_strip(e, so)};
}

std::shared_ptr<const IndexedArtwork> PlacementStore::shared_artwork(const IndexedArtwork* artwork) const {
  for (const auto& a : artworks_)
    if (a.get() == artwork) return a;
  return nullptr;
}

SampledProfile PlacementStore::sample(const PatternRef& r, const PatternFrame& f,
                                      const ProfileSamplingOptions& so) const {
  const ElementLayout e = local_element(r);
  const IndexedArtwork artwork(local_artwork(D_, r, e, f), 0.0);
  return sample_placement(lum_, {&f, &artwork, element_strip(e, so)}, so, D_.light_bars, clip_);
}

ProfileSamplingOptions PlacementStore::fitted_in_view(const PatternRef& r, const PatternFrame& f,
                                                      ProfileSamplingOptions so) const {
  const ElementLayout e = local_element(r);
  const double w_max = lum_.cols - 1, h_max = lum_.rows - 1;
  for (;;) {
    const Strip s = element_strip(e, so);
    const double u = s.half_u_mm, v = s.half_v_mm;
    bool inside = true;
    for (const Vec2 corner : {Vec2{-u, -v}, Vec2{u, -v}, Vec2{u, v}, Vec2{-u, v}}) {
      const Vec2 plane = s.bars == BarOrientation::vertical_bars ? corner : Vec2{corner.y, corner.x};
      const Vec2 q = *f.project(s.center_mm + plane);
      inside = inside && q.x >= 0 && q.y >= 0 && q.x <= w_max && q.y <= h_max;
    }
    if (inside || so.margin_bar_widths <= 0.5) return so;
    so.margin_bar_widths = std::max(0.5, so.margin_bar_widths - 0.25);
  }
}

PatternFrame PlacementStore::recentre(const PatternRef& r, PatternFrame f, const ProfileSamplingOptions& so) const {
  const SampledProfile p = sample(r, f, so);
  if (!p.in_view) return f;
  const double shift_mm = refine_shift(p.data, r.bar_width_mm(), D_.light_bars);
  f.center_px = f.center_px + (shift_mm * f.px_per_mm) * across_dir(f, r.orientation);
  return f;
}

int period_slip(const ProfileData& d, double w_mm, bool light) {
  const Detrended t = detrended(d);
  return t.r.empty() ? 0 : period_slip_of(t, w_mm, light);
}

std::optional<PatternFrame> PlacementStore::unslipped(const PatternRef& r, const PatternFrame& f,
                                                      const ProfileSamplingOptions& so) const {
  // The windows one period along reach 5.25 bar widths from the centre:
  // the strip's half-length 2.5 w plus a margin of 2.75 w or more.
  ProfileSamplingOptions wide = so;
  wide.margin_bar_widths = 3;
  wide = fitted_in_view(r, f, wide);
  if (wide.margin_bar_widths < 2.75) return std::nullopt;
  const SampledProfile p = sample(r, f, wide);
  if (!p.in_view) return std::nullopt;
  const double w_mm = r.bar_width_mm();
  const int slip = period_slip(p.data, w_mm, D_.light_bars);
  if (slip == 0) return std::nullopt;
  PatternFrame g = f;
  g.center_px = f.center_px + (2 * slip * w_mm * f.px_per_mm) * across_dir(f, r.orientation);
  return recentre(r, g, so);
}

// The shift the profile model itself prefers: one fit with the bars'
// shift free (ProfileFitOptions::fit_shift), within a quarter of a bar.
// The correlation centring (refine_shift) gets within a tenth of a bar or
// so; at sharp edges and near the limit that residue would still read as
// blur. Where the data do not place the pattern (a degenerate fit; the
// shift's sigma a tenth of a bar or more: a faint pattern's fit would
// chase its noise; or the shift stopped at the range's edge, where Ceres'
// covariance, blind to the bound, still reads small), the pattern stays
// where it was.
constexpr double kMaxShiftBars = 0.25;  // with_free_shift's range, in bar widths either way

ProfileFitOptions with_free_shift(ProfileFitOptions fo, double w_mm) {
  fo.fit_shift = true;
  fo.max_shift_mm = kMaxShiftBars * w_mm;
  return fo;
}

bool shift_placed(const ProfileFit& f, double w_mm) {
  return f.usable && f.shift_sigma_mm < 0.1 * w_mm && std::abs(f.shift_mm) < 0.99 * kMaxShiftBars * w_mm;
}

ProfileData refine_shift_by_fit(const ProfileData& d, const ProfileFitOptions& options, double w_mm,
                                double* shift_mm) {
  const ProfileFitOptions fo = with_free_shift(options, w_mm);
  if (shift_mm) *shift_mm = 0;
  const ProfileFit f = fit_profile(d, fo);
  if (!shift_placed(f, w_mm)) return d;
  if (shift_mm) *shift_mm = f.shift_mm;
  return shifted_ideal(d, f.shift_mm);
}

// The vertex of chi^2 over three stretched ideals. Only well-sampled,
// well-modulated patterns pin the scale down.
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

double PlaneField::at(Vec2 p) const { return c[0] + c[1] * p.x + c[2] * p.y; }

PlaneField fit_plane_field(const std::vector<std::pair<Vec2, double>>& samples) {
  PlaneField f;
  if (samples.empty()) return f;
  double mean = 0;
  for (const auto& s : samples) mean += s.second;
  mean /= samples.size();
  f.c[0] = mean;
  f.valid = true;
  if (samples.size() < 4) return f;  // too few for a gradient: constant
  cv::Mat A(static_cast<int>(samples.size()), 3, CV_64F), b(static_cast<int>(samples.size()), 1, CV_64F);
  for (size_t i = 0; i < samples.size(); ++i) {
    A.at<double>(int(i), 0) = 1;
    A.at<double>(int(i), 1) = samples[i].first.x;
    A.at<double>(int(i), 2) = samples[i].first.y;
    b.at<double>(int(i)) = samples[i].second;
  }
  cv::Mat x;
  if (!cv::solve(A, b, x, cv::DECOMP_SVD)) return f;
  for (int k = 0; k < 3; ++k) f.c[k] = x.at<double>(k);
  return f;
}

double ScaleField::at(Vec2 p) const { return std::exp(log_scale.at(p)); }

double ScaleField::at_or(Vec2 p, double own_px_per_mm) const {
  const double px_per_mm = at(p);
  return std::abs(std::log(px_per_mm / own_px_per_mm)) <= kMaxLogDeviation ? px_per_mm : own_px_per_mm;
}

ScaleField fit_scale_field(const std::vector<std::pair<Vec2, double>>& samples) {
  std::vector<std::pair<Vec2, double>> logs;
  for (const auto& [p, px_per_mm] : samples) logs.push_back({p, std::log(px_per_mm)});
  ScaleField f;
  f.log_scale = fit_plane_field(logs);
  f.valid = f.log_scale.valid;
  return f;
}

}  // namespace tactres::chart
