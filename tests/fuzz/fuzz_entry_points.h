#pragma once
// Entry points shared by the libFuzzer targets (fuzz_target.cpp, one binary
// per entry, built by scripts/fuzz.sh) and by the stability suite, which
// replays the corpus seeds and every input kept in tests/fuzz/regressions/
// through the same functions without libFuzzer.
//
// Each entry feeds arbitrary bytes to one reader or numerical routine of
// tactres. Documented errors (std::invalid_argument, std::runtime_error and
// UnusableInput) are the expected answer to bad bytes and are swallowed.
// Anything else is a bug: a crash, a sanitizer report, another exception
// escaping, or a broken invariant of an accepted input (e.g. a NaN in a
// fitted result), which aborts with a message on stderr.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "tactres/profiles/profile_fit.h"

namespace tactres::fuzz {

using EntryFn = void (*)(const std::uint8_t* data, std::size_t size);

struct Entry {
  const char* name;  // also the folder name under tests/fuzz/corpus and regressions
  EntryFn fn;
  const char* what;
};

// layout_json, scene_json, measurement_json, camera_model, image,
// profile_fit, measure_raw.
std::span<const Entry> entries();
const Entry* find_entry(const std::string& name);

// Encoders for the binary formats of two entries, so that seeds and tests
// can build valid inputs.
//
// profile_fit: the byte layout is described above profile_fit() in the .cpp.
// measure_raw: "TRAW", u16 width, u16 height, u8 flags, then width * height
// 8-bit pixels (value / 255; with flags bit 0, byte 255 is NaN; with bit 1,
// byte 254 is +Inf). Flags bit 2 measures with the example pinhole camera
// model scaled to the image instead of fitting a pinhole; bits 3-4 pick the
// preset.
std::string encode_profile_fit(const ProfileData& data, const ProfileFitOptions& options);
std::string encode_measure_raw(int width, int height, std::uint8_t flags, const std::uint8_t* pixels);

}  // namespace tactres::fuzz
