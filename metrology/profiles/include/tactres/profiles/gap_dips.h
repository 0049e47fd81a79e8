#pragma once
// Whether a three-bar profile shows both of its gaps: a model-free check
// beside the profile model's m (profile_fit.h).
//
// The model fits one blur to the whole triplet, so its m averages over the
// bars. Where the blur differs across a triplet (field curvature, flare
// from a bright neighbour), one gap can fill up into a plateau while the
// other still dips: the model still reads m well above the threshold, yet
// an observer sees two bars, not three, and USAF-1951 calls such an
// element not resolved. The check compares the data in narrow windows at
// the bar and gap centres, as a person reading the profile does.
//
// Units: u and widths in mm of the target plane (the profile's own);
// dips in the profile's value units.

#include <optional>

#include "tactres/profiles/profile_fit.h"

namespace tactres {

struct GapDips {
  // Every bar and gap window held samples (at least one unclipped bin).
  bool valid = false;
  // Per gap, left to right: how far the gap lies below the weaker of its
  // two bars, towards the ground (positive: the gap dips), and the
  // standard error of that difference from the bins' own errors.
  double dip[2] = {0, 0};
  double sigma[2] = {0, 0};
  // The ground just outside the triplet: the mean of its unclipped bins
  // from half a bar width to one and a half beyond each outer bar's edge,
  // in the profile's value units; 0 when neither side holds one.
  double ground = 0;

  // The gap (0 or 1) that shows no dip (under 2 sigma, or under
  // kMinGapDipRatio of the other's) while the other clearly does (over 5
  // sigma, so the data could show one there), if any. Two shallow gaps are the model's business (a
  // blurred element reads a low m), not this check's.
  static constexpr double kMinGapDipRatio = 0.1;  // fixed, not the criterion's threshold
  std::optional<int> flat_gap() const;

  // Both gaps dip clearly (each over 5 sigma): the data show all three
  // bars where the ideal puts them, whatever a model makes of their shape.
  bool three_bars() const;
};

// The dips of the measured triplet of `d`: its three bars are the ideal's
// boxes of width ~bar_width_mm nearest u = 0 (after any shift of the
// ideal); `contrast` is the model's level step (profile_fit.h), whose sign
// with the ideal's says which way the bars go. `pixel_mm`, the image's
// pixel pitch across the bars, makes every window at least one pixel wide:
// at under 2 px per bar a frame aligned with the bars samples the profile
// once per pixel, and a narrower window could hold no sample at all.
GapDips gap_dips(const ProfileData& d, double bar_width_mm, double contrast, double pixel_mm = 0);

}  // namespace tactres
