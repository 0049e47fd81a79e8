#include "tactres/util/order_stats.h"

#include <doctest/doctest.h>

using namespace tactres;

TEST_CASE("order statistics: percentile interpolates, median and mean of samples") {
  const std::vector<double> v{4, 1, 3, 2};
  CHECK(percentile(v, 0.0) == 1);
  CHECK(percentile(v, 1.0) == 4);
  CHECK(percentile(v, 0.5) == doctest::Approx(2.5));
  CHECK(median(v) == doctest::Approx(2.5));
  CHECK(mean(v) == doctest::Approx(2.5));
  CHECK(median({}) == 0);
}

TEST_CASE("order statistics: the sample standard deviation divides by n - 1, and is 0 below two values") {
  // 2, 4, 4, 4, 5, 5, 7, 9: squared deviations from 5 sum to 32.
  CHECK(sample_sd({2, 4, 4, 4, 5, 5, 7, 9}) == doctest::Approx(std::sqrt(32.0 / 7)));
  CHECK(sample_sd({-0.94, -0.94}) == 0);
  CHECK(sample_sd({1.5}) == 0);
  CHECK(sample_sd({}) == 0);
}
