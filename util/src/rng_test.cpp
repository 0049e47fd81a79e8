#include <doctest/doctest.h>

#include "tactres/util/rng.h"

using namespace tactres;

TEST_CASE("splitmix64: the published reference values, and uniform01 between 0 and 1 with a sane mean") {
  // First outputs of SplitMix64 seeded with 0 (state advanced by the golden gamma each call).
  CHECK(splitmix64(0) == 0xE220A8397B1DCDAFull);
  CHECK(splitmix64(0x9E3779B97F4A7C15ull) == 0x6E789E6AA1B965F4ull);
  double sum = 0;
  for (std::uint64_t k = 0; k < 10000; ++k) {
    const double u = uniform01(3, k);
    REQUIRE(u >= 0.0);
    REQUIRE(u < 1.0);
    sum += u;
  }
  CHECK(sum / 10000 == doctest::Approx(0.5).epsilon(0.02));
  CHECK(uniform01(3, 7) == uniform01(3, 7));
  CHECK(uniform01(3, 7) != uniform01(4, 7));
}
