#pragma once
// The USAF-1951 frequency series (MIL-STD-150A): element e of group g has
// lp/mm = 2^(g + (e - 1) / 6). A bar is half a line pair wide, 5 widths long,
// and bars of a triplet are one width apart.

namespace tactres {

constexpr int kUsafElementsPerGroup = 6;
constexpr double kUsafBarLengthInWidths = 5.0;  // MIL-STD-150A: a bar is 5 widths long

double usaf_lp_per_mm(int group, int element);
double usaf_bar_width_mm(int group, int element);  // 1 / (2 lp/mm)
double usaf_bar_length_mm(int group, int element);  // 5 bar widths

// The series index of an element, 6 group + element - 1 (G0E1 is 0, G-1E6
// is -1), and back.
struct UsafElement {
  int group = 0, element = 1;
};
inline int usaf_index(int group, int element) { return kUsafElementsPerGroup * group + element - 1; }
UsafElement usaf_element_at(int index);

}  // namespace tactres
