#pragma once
// Profiles across the bars, sampled in target millimetres.
//
// A strip is a rectangle in the target plane: centre c, across-axis u
// (x or y) and along-axis v. Every pixel whose centre maps into the strip
// (through the plane's map to the image, camera/plane_map.h: the pose and
// the lens model in layout mode, never through an undistorted copy)
// contributes its value at its own u (every k-th row and column only where
// the bins would hold thousands each, ProfileSamplingOptions::
// dense_bin_samples): pixels are binned by u at a fraction
// of a pixel, which averages along the bars and oversamples the profile the
// way a slanted edge does. Strictly, by w, u's distance in pixels divided
// by the centre's scale (docs/CONVENTIONS.md, "The measurand m(f)"): the
// blur is the same in pixels everywhere, not in millimetres, and the
// ProfileData's u coordinates and ideal boxes are in w. The ideal pattern S(u) of every artwork shape in
// the strip comes from the layout, so neighbours are modelled, not ignored.

#include <array>

#include <opencv2/core/mat.hpp>

#include "tactres/profiles/profile_fit.h"
#include "tactres/camera/plane_map.h"
#include "tactres/targets/coverage.h"
#include "tactres/targets/layout.h"

namespace tactres {

struct ProfileSamplingOptions {
  double bin_px = 0.25;             // bin width across the bars, in pixels: a preset's in [0.05, 1],
                                    // widened on coarse elements (MeasureOptions::bin_px_for)
  double along_fraction = 0.7;      // central share of the bar length used, (0, 1]
  double margin_bar_widths = 1.5;   // fit window beyond the outer bars, [0.5, 5]
  // A strip whose bins would each hold more than 9x this many pixels (an
  // element hundreds of px wide filling a 4K frame: 15 000 a bin) is read
  // on every k-th row and column, k odd, the largest that leaves this many
  // a bin on average and is no wider than a bin. [16, 1e6]
  double dense_bin_samples = 256;
  void validate() const;            // throws std::invalid_argument
};

struct Strip {
  Vec2 center_mm;
  BarOrientation bars = BarOrientation::vertical_bars;  // u runs across them: along x for vertical bars
  double half_u_mm = 0;       // fit window half width
  double half_v_mm = 0;       // along-bar half length
  double extend_u_mm = 0;     // extra ideal pattern beyond the window
};

struct SampledProfile {
  ProfileData data;
  bool in_view = false;
  double px_per_mm_across = 0;      // image scale across the bars at the centre
  double px_per_mm_along = 0;       // image scale along the bars at the centre
  int pixels_used = 0;
  int pixels_clipped = 0;           // at or beyond the clip level
  int pixels_masked = 0;            // non-finite (masked) pixels in the strip
  std::array<Vec2, 4> outline_px{}; // strip corners in the image, for overlays
  double map_error_px = 0;          // residual of the local pixel -> target map
  double noise_sd = 0;              // per-pixel noise estimated from flat bins, at their mean level
  // The per-pixel noise model var(level) = noise_var_offset + noise_var_per_level * level
  // (read plus shot noise, EMVA 1288), fitted to the scatter along the bars
  // in the flattest bins; `noise_dof`, the degrees of freedom behind it.
  // A single frame cannot tell temporal noise from fixed texture along the
  // bars (a gel's grain, print dots): both enter, so on a textured target
  // this is an upper bound of the temporal noise.
  double noise_var_offset = 0, noise_var_per_level = 0, noise_dof = 0;
  double noise_sd_at(double level) const;
};

// `clip_level` <= 0 disables clipping detection (float images).
SampledProfile sample_strip(const cv::Mat& luminance, const PlaneToImage& plane, const IndexedArtwork& artwork,
                            const Strip& strip, const ProfileSamplingOptions& options, double clip_level);

// Light bars on a dark ground (a negative chart): the ideal becomes the
// complement, 1 - S(u), so the model is the same as for dark bars. The
// constant is a box over exactly the profile's bins: the model evaluates
// the pattern's spectrum on that (periodic) grid, where such a box is a
// pure constant, and a wider one would not be 1.
void complement_ideal(ProfileData& d);
// Whether `b` is that constant box (moving or scaling the pattern leaves it).
bool is_complement_box(const ProfileData& d, const IdealBox& b);

// The strip of an element (bars across u) and of the reference patch.
Strip element_strip(const ElementLayout& e, const ProfileSamplingOptions& options);
Strip patch_strip(const TargetLayout& layout, BarOrientation bars);

}  // namespace tactres
