#pragma once
// TargetLayout: the single source of truth for the USAF-1951-style target.
// Every emitter (SVG, raster, height map, STL, layout JSON), the simulator
// and the analyzer read this value; nothing re-derives the geometry.
//
// Frame: millimetres, origin at the top-left corner of the printed face,
// x right, y down, z into the target (relief rises along -z).

#include <array>
#include <string>
#include <vector>

#include "tactres/targets/geometry.h"

namespace tactres {

inline constexpr const char* kLayoutSchema = "tactres.target/1";

// "horizontal_bars": long side along x, so they resolve detail along y.
enum class BarOrientation { horizontal_bars, vertical_bars };
// Which way the inked (or raised) shapes appear in a printed raster.
enum class Polarity { dark_bars_on_light, light_bars_on_dark };

const char* to_string(BarOrientation o);
const char* to_string(Polarity p);
BarOrientation bar_orientation_from_string(const std::string& s);  // throws invalid_argument
Polarity polarity_from_string(const std::string& s);               // throws invalid_argument

// One triplet of bars: a USAF element in one orientation.
struct ElementLayout {
  int group = 0;
  int element = 1;
  double lp_per_mm = 1.0;
  double bar_width_mm = 0.5;
  BarOrientation orientation = BarOrientation::horizontal_bars;
  std::array<RectMm, 3> bars_mm{};

  RectMm extent_mm() const { return bounding_union(bars_mm[0], bounding_union(bars_mm[1], bars_mm[2])); }
};

struct Fiducial {
  std::string id;  // "TL", "TR", "BL", "BR", "T3" (top edge, a third from TL)
  Vec2 center_mm;
  double radius_mm = 0.5;
};

// An inked (printed) or raised (relief) shape. Drawing order is list order.
struct ArtworkShape {
  enum class Kind { rect, disc, polygon };
  enum class Role { bar, patch, fiducial, label };
  Kind kind = Kind::rect;
  Role role = Role::bar;
  RectMm rect_mm;                 // kind == rect
  Vec2 center_mm;                 // kind == disc
  double radius_mm = 0.0;         // kind == disc
  std::vector<Vec2> polygon_mm;   // kind == polygon (simple, either winding)

  RectMm bounds_mm() const;
  double area_mm2() const;
};

struct TargetLayout {
  double width_mm = 20.0;
  double height_mm = 20.0;
  Polarity polarity = Polarity::dark_bars_on_light;
  double relief_height_mm = 0.1;     // bar tops above the ground
  double base_thickness_mm = 2.0;    // relief plate under the ground level
  int first_group = 0;
  int last_group = 4;
  std::vector<ElementLayout> elements;
  RectMm reference_patch_mm;
  std::vector<Fiducial> fiducials;
  std::vector<ArtworkShape> artwork;

  double inked_area_mm2() const;  // sum of artwork areas (shapes never overlap)
  const ElementLayout* find(int group, int element, BarOrientation o) const;
};

// Options for make_layout(). Defaults are the documented defaults.
struct LayoutOptions {
  int first_group = 0;               // coarsest group (any integer)
  int last_group = 4;                // finest group, >= first_group
  double field_width_mm = 20.0;      // (0, 1000]
  double field_height_mm = 20.0;     // (0, 1000]
  double relief_height_mm = 0.1;     // (0, 10]
  double base_thickness_mm = 2.0;    // (0, 100]
  Polarity polarity = Polarity::dark_bars_on_light;

  // Throws std::invalid_argument naming the bad option and its valid range.
  void validate() const;
};

// The option checks every target shares (the packed layout and the
// MIL-STD-150A chart). Each throws std::invalid_argument naming the bad
// option and its valid range: groups in -10..12 with last >= first; relief
// height in (0, 10] mm, base thickness in (0, 100] mm.
void validate_group_range(int first_group, int last_group);
void validate_relief(double relief_height_mm, double base_thickness_mm);

// Packs the elements, the reference patch, the fiducials and the labels into
// the field. Throws std::invalid_argument if the groups do not fit, saying
// which groups would fit in that field and which field the groups need.
TargetLayout make_layout(const LayoutOptions& options);

// Geometry of the packing, exposed for the generator's tests and for the
// analyzer's choice of profile windows: every triplet keeps a clear margin of
// kQuietZoneBarWidths bar widths on all sides to any other shape.
inline constexpr double kQuietZoneBarWidths = 1.0;

}  // namespace tactres
