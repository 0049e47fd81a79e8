// One libFuzzer target per entry point of fuzz_entry_points.h; CMake
// compiles this file once per entry with TACTRES_FUZZ_ENTRY set to its name
// (tests/CMakeLists.txt, TACTRES_FUZZ). Build and run: scripts/fuzz.sh.
#include <cstdio>
#include <cstdlib>

#include "fuzz_entry_points.h"

namespace {
tactres::fuzz::EntryFn entry_fn() {
  static const tactres::fuzz::Entry* e = tactres::fuzz::find_entry(TACTRES_FUZZ_ENTRY);
  if (!e) {
    std::fprintf(stderr, "no fuzz entry named %s\n", TACTRES_FUZZ_ENTRY);
    std::abort();
  }
  return e->fn;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  entry_fn()(data, size);
  return 0;
}
