#include "tactres/measure/element_grading.h"

#include <doctest/doctest.h>

using namespace tactres;

namespace {

// One orientation of group 2, elements 1..6, with the given m (sigma 0.02).
Measurement row_of(const std::vector<double>& m) {
  Measurement M;
  for (size_t i = 0; i < m.size(); ++i) {
    const int element = static_cast<int>(i) + 1;
    ElementResult r = ElementResult::of(2, element, BarOrientation::vertical_bars, 4.0 * std::exp2(i / 6.0), 5.0);
    r.status = ElementStatus::ok;
    r.m = m[i];
    r.m_sigma = 0.02;
    M.elements.push_back(r);
  }
  return M;
}

}  // namespace

TEST_CASE("damaged: an element without bars before two finer resolved ones is left out of the limit") {
  Criterion c;
  Measurement M = row_of({0.8, 0.02, 0.7, 0.6, 0.4, 0.05});
  grade_damaged(M, c);
  CHECK(M.elements[1].status == ElementStatus::damaged);
  CHECK(M.elements[1].note.find("G2E3 and G2E4") != std::string::npos);
  // The finest unresolved one has no finer neighbours: the optics.
  CHECK(M.elements[5].status == ElementStatus::ok);
  decide_limits(M, c, {}, true);
  CHECK_FALSE(M.elements[1].resolved);
  const Limit& optical = M.vertical_parts.optical;  // (no CNR here, so no detectability limit)
  CHECK(optical.group == 2);
  CHECK(optical.element == 5);
  REQUIRE(optical.bridged.size() == 1);
  CHECK(optical.bridged[0].element == 2);
}

TEST_CASE("damaged: not when a finer neighbour is unresolved or within the errors") {
  Criterion c;
  // E2 fails, E3 resolved, E4 not: an ordinary limit at E1.
  Measurement a = row_of({0.5, 0.05, 0.3, 0.05, 0.02, 0.01});
  grade_damaged(a, c);
  for (const ElementResult& e : a.elements) CHECK(e.status == ElementStatus::ok);
  // E2 just below the threshold, its finer neighbours just above it: no
  // significant rise with frequency, so no defect is claimed.
  Measurement b = row_of({0.5, 0.09, 0.11, 0.12, 0.05, 0.02});
  grade_damaged(b, c);
  CHECK(b.elements[1].status == ElementStatus::ok);
  // An aliased element (no bars at all) before two resolved ones is damaged.
  Measurement d = row_of({0.8, 0.0, 0.7, 0.6, 0.4, 0.05});
  d.elements[1].status = ElementStatus::aliased;
  grade_damaged(d, c);
  CHECK(d.elements[1].status == ElementStatus::damaged);
}
