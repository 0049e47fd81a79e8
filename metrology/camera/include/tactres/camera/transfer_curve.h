#pragma once
// How a capture's code values map to linear light, and how tactres decides
// which curve a file uses (docs/CONVENTIONS.md, "Pixels in").
//
// The policy, in order:
//  1. `--transfer linear|srgb|gamma:G` forces a curve.
//  2. Otherwise the file's explicit colour metadata decides: a PNG sRGB,
//     iCCP or gAMA chunk, an embedded ICC profile, EXIF ColorSpace = sRGB,
//     or a format that is linear by definition (OpenEXR).
//  3. Otherwise the bit depth decides: 8-bit integer means sRGB (the
//     convention of photographs and displays); 16-bit integer and float mean
//     linear (the convention of scientific and machine-vision cameras).
// The decision carries a reason that the measurement JSON and the one-line
// summary print, e.g. "16-bit, no colour tag".

#include <optional>
#include <string>

namespace tactres {

struct TransferCurve {
  enum class Kind { linear, srgb, power };
  Kind kind = Kind::linear;
  double gamma = 1.0;  // Kind::power: linear = code^gamma

  static TransferCurve linear() { return {}; }
  static TransferCurve srgb() { return {Kind::srgb, 1.0}; }
  static TransferCurve power(double gamma);  // gamma in [0.2, 5]; gamma ~ 1 is linear

  std::string name() const;    // "linear", "srgb", "gamma 2.2"
  std::string option() const;  // what forces it: "--transfer srgb"
  // code value (file, [0, 1] for integers) -> linear light, and back.
  // Monotone; both keep the sign of values below 0 (float files) and map
  // NaN to NaN.
  float to_linear(float code) const;
  float to_code(float linear) const;
  bool same_as(const TransferCurve& o) const;
};

// `--transfer`: "auto" gives nullopt; "linear", "srgb", "gamma:G". Throws
// std::invalid_argument with the accepted spellings.
std::optional<TransferCurve> transfer_from_option(const std::string& text);

// What a file says about its own encoding, read by image_io.
struct ColourTag {
  bool present = false;
  TransferCurve curve;
  std::string source;  // e.g. "PNG sRGB chunk", "EXIF ColorSpace sRGB"
};

struct TransferDecision {
  TransferCurve curve;
  std::string reason;  // why this curve, for people: "16-bit, no colour tag"
  // True when no option and no tag decided, only the bit depth: another
  // curve that fits the reference patch far better may then replace it.
  bool guessed = false;
};

// What the reference patch said about the curve (reference_patch.h,
// check_transfer).
struct TransferCheck {
  bool checked = false;   // the patch fitted poorly enough to try other curves
  bool mismatch = false;  // another curve describes the patch far better
  std::string applied;    // the curve the pixels were decoded with
  std::string best;       // the best-fitting curve tried (may equal `applied`)
  double chi2_applied = 0, chi2_best = 0;  // worse of the two patch directions
  std::optional<TransferCurve> switch_to;  // the caller should re-decode with this
  std::string message;    // for people; empty when nothing was found
};

TransferDecision decide_transfer(const std::optional<TransferCurve>& forced, const ColourTag& tag,
                                 bool integer_format, int bits_per_sample);

}  // namespace tactres
