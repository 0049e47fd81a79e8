#include "tactres/targets/usaf_series.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace tactres {

double usaf_lp_per_mm(int group, int element) {
  if (element < 1 || element > kUsafElementsPerGroup)
    throw std::invalid_argument("USAF element must be 1..6, got " + std::to_string(element));
  return std::exp2(group + (element - 1) / 6.0);
}

UsafElement usaf_element_at(int index) {
  const int group = index >= 0 ? index / kUsafElementsPerGroup
                               : -((-index + kUsafElementsPerGroup - 1) / kUsafElementsPerGroup);
  return {group, index - kUsafElementsPerGroup * group + 1};
}

double usaf_bar_width_mm(int group, int element) { return 0.5 / usaf_lp_per_mm(group, element); }

double usaf_bar_length_mm(int group, int element) { return kUsafBarLengthInWidths * usaf_bar_width_mm(group, element); }

}  // namespace tactres
