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
// directions follow one smooth field. The field checked here is the
// simplest that covers both and the distant light:
//
//     d(q) = lambda (s - q)        (a focus s, toward it or away from it)
//     d(q) = a                      (its limit as s goes to infinity)
//
// i.e. d(q) = (u - lambda q.x, v - lambda q.y), three numbers up to scale.
// Radial fields are exact under a projective view (lines through s map to
// lines through its image), so a uniform light under perspective (radial
// toward a vanishing point) is one as well.
//
// Texture and random blobs have crescents in unrelated directions: each
// disc's direction is compared with the field fitted to the OTHER discs
// (leave one out), so one stray disc cannot pull the field toward itself.

#include <vector>

#include "tactres/targets/geometry.h"

namespace tactres::locate_detail {

// The largest angle (degrees, 0-180) between a disc's dipole and the
// direction the field fitted to the other discs predicts at its centre,
// over the discs (with three discs, or where the others leave the field
// undetermined, the field fitted to all). 180 when the discs cannot be
// checked: fewer than 3, a
// dipole of zero length, a fit that leaves a disc at the field's zero (a
// strong crescent cannot sit where the in-plane light vanishes), or
// collinear discs. centres_px and dipoles_px are parallel, image px.
double light_field_deviation_deg(const std::vector<Vec2>& centres_px, const std::vector<Vec2>& dipoles_px);

// Largest light_field_deviation_deg() of relief discs accepted as lit by
// one light. A distant light under one tilted view stays within ~10
// degrees; the modelled light paths' spots and rims within ~25
// (fiducial_light_field_test.cpp); random directions pass rarely.
inline constexpr double kMaxLightFieldDeviationDeg = 35.0;

}  // namespace tactres::locate_detail
