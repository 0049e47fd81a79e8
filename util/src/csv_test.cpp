#include <cmath>

#include <doctest/doctest.h>

#include "tactres/util/csv.h"

using namespace tactres;

TEST_CASE("csv_cell quotes only what needs it, and doubles inner quotes") {
  CHECK(csv_cell("T1C1") == "T1C1");
  CHECK(csv_cell("a,b") == "\"a,b\"");
  CHECK(csv_cell("say \"hi\"") == "\"say \"\"hi\"\"\"");
  CHECK(csv_cell("two\nlines") == "\"two\nlines\"");
  CHECK(csv_cell("") == "");
}

TEST_CASE("csv_number: fixed decimals, and an empty cell for none, NaN and infinity") {
  CHECK(csv_number(7.1271, 2) == "7.13");
  CHECK(csv_number(-0.5, 3) == "-0.500");
  CHECK(csv_number(std::nullopt, 2).empty());
  CHECK(csv_number(NAN, 2).empty());
  CHECK(csv_number(INFINITY, 2).empty());
}
