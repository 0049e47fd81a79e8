#pragma once
// Private to locate: whether the light crescents of a relief's fiducial
// discs could all come from one light (fiducial_verify.cpp).
//
// Under a relief seen through a gel each disc shows a light and a dark
// crescent; their dipole (fiducials_internal.h, Refined::dipole) points
// along the in-plane part of the light at the disc. One distant light gives
// every disc the same direction, but a light spread below the gel does not:
// a bright spot's in-plane part points radially toward it, a lit rim's away
// from the middle (docs/LIGHT_PATH.md, "Off the centre"), so the direction
// turns by up to ~180 degrees over the target. What stays true is that the
// directions follow one smooth field. Two fields are checked:
//
//   focus:   d(q) = lambda (s - q)   toward a point s or away from it: a
//            spot, a lit rim, and a distant light (s at infinity). Radial
//            fields are exact under a projective view (lines through s
//            map to lines through its image), so a distant light under
//            perspective (radial toward a vanishing point) is one too.
//   linear:  d(q) = a + B q, B symmetric: the first-order field about the
//            target's middle of any light that has no curl, such as an
//            elongated window (its light points across the window's long
//            axis, toward the axis; a focus cannot follow that).
//
// Texture and random blobs have crescents in unrelated directions: each
// disc's direction is compared with the field fitted to the OTHER discs
// (leave one out), so one stray disc cannot pull the field toward itself.
// The focus has 2 degrees of freedom, the linear field 4: with five discs
// the focus leaves 3 directions to check, the linear field 1, so its
// tolerance is tighter, and with four discs it checks nothing (only the
// focus applies).

#include <vector>

#include "tactres/targets/geometry.h"

namespace tactres::locate_detail {

// The largest angle (degrees, 0-180) between a disc's dipole and the
// direction each field fitted to the other discs predicts at its centre,
// over the discs (where the others leave the field undetermined, the
// field fitted to all). 180 when the discs cannot check the field: too few
// for its freedom, a dipole of zero length, a disc at the field's zero (a
// strong crescent cannot sit where the in-plane light vanishes).
struct LightFieldDeviation {
  double focus_deg = 180;
  double linear_deg = 180;
};

// centres_px and dipoles_px are parallel, image px.
LightFieldDeviation light_field_deviation(const std::vector<Vec2>& centres_px, const std::vector<Vec2>& dipoles_px);

// Tolerances. A distant light, also under a tilted view, fits the focus
// within a few degrees; the shipped designs' captures (docs/LIGHT_PATH.md)
// fit it within 2-11 degrees, except the long windows: T1C3 35 degrees
// (between a spot and a line), T1C4 74, which the linear field follows
// within 6-7. Random directions pass 0.6 % of five discs, 1.75 % of four
// (fiducial_light_field_test.cpp).
inline constexpr double kMaxFocusDeviationDeg = 45.0;
inline constexpr double kMaxLinearDeviationDeg = 15.0;

// Whether the crescents follow one light: either field within its tolerance.
bool follows_one_light(const LightFieldDeviation& d);

}  // namespace tactres::locate_detail
