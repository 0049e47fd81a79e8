#include <atomic>
#include <vector>

#include <doctest/doctest.h>

#include "tactres/util/parallel.h"

using namespace tactres;

TEST_CASE("for_each_index runs every index exactly once, with one thread or many") {
  for (int threads : {1, 2, 0}) {
    std::vector<std::atomic<int>> hits(257);
    for_each_index(hits.size(), threads, [&](std::size_t i) { hits[i]++; });
    for (const auto& h : hits) CHECK(h.load() == 1);
  }
  int calls = 0;
  for_each_index(0, 2, [&](std::size_t) { ++calls; });
  CHECK(calls == 0);
}
