#include "tactres/util/rng.h"

namespace tactres {

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

double uniform01(std::uint64_t stream, std::uint64_t k) {
  return double(splitmix64(splitmix64(0x7AC7E5BE4C4ull + stream) + k) >> 11) * 0x1.0p-53;
}

}  // namespace tactres
