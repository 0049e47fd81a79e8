#pragma once
// Reproducible random numbers: integer-only, so the same seed gives the
// same draws on every platform (std:: distributions are
// implementation-defined). Used for sensor noise and the bench suite.

#include <cstdint>

namespace tactres {

// SplitMix64 (Steele, Lea & Flood, "Fast splittable pseudorandom number
// generators", OOPSLA 2014): a bijective mix of a 64-bit counter.
std::uint64_t splitmix64(std::uint64_t x);

// The k-th uniform draw in [0, 1) of stream `stream` (53-bit resolution).
double uniform01(std::uint64_t stream, std::uint64_t k);

}  // namespace tactres
