#include "tactres/camera/transfer_curve.h"

#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

namespace tactres {

namespace {

// A power law this close to 1 is linear for every purpose here (0.4 % of a
// stop at mid-grey); calling it linear keeps names and JSON simple.
constexpr double kLinearGammaTolerance = 0.01;

// IEC 61966-2-1 sRGB, decoding and encoding.
float srgb_decode(float v) { return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f); }
float srgb_encode(float v) { return v <= 0.0031308f ? v * 12.92f : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f; }

// Curves are defined on [0, 1]; float files may hold values below 0, which
// are mirrored (an odd extension) so the mapping stays monotone.
template <typename F>
float odd(float v, F f) {
  return v < 0 ? -f(-v) : f(v);
}

}  // namespace

TransferCurve TransferCurve::power(double gamma) {
  if (!(gamma >= 0.2 && gamma <= 5.0))
    throw std::invalid_argument(fmt::format("a transfer gamma must be in [0.2, 5], not {}", gamma));
  if (std::abs(gamma - 1.0) <= kLinearGammaTolerance) return linear();
  return {Kind::power, gamma};
}

std::string TransferCurve::name() const {
  switch (kind) {
    case Kind::linear: return "linear";
    case Kind::srgb: return "srgb";
    case Kind::power: return fmt::format("gamma {:.3g}", gamma);
  }
  return "linear";
}

std::string TransferCurve::option() const {
  return kind == Kind::power ? fmt::format("--transfer gamma:{:.3g}", gamma) : "--transfer " + name();
}

float TransferCurve::to_linear(float code) const {
  switch (kind) {
    case Kind::linear: return code;
    case Kind::srgb: return odd(code, srgb_decode);
    case Kind::power: return odd(code, [g = float(gamma)](float v) { return std::pow(v, g); });
  }
  return code;
}

float TransferCurve::to_code(float linear_value) const {
  switch (kind) {
    case Kind::linear: return linear_value;
    case Kind::srgb: return odd(linear_value, srgb_encode);
    case Kind::power: return odd(linear_value, [g = float(1.0 / gamma)](float v) { return std::pow(v, g); });
  }
  return linear_value;
}

bool TransferCurve::same_as(const TransferCurve& o) const {
  return kind == o.kind && (kind != Kind::power || std::abs(gamma - o.gamma) < 1e-9);
}

std::optional<TransferCurve> transfer_from_option(const std::string& text) {
  if (text == "auto") return std::nullopt;
  if (text == "linear") return TransferCurve::linear();
  if (text == "srgb") return TransferCurve::srgb();
  const std::string prefix = "gamma:";
  if (text.rfind(prefix, 0) == 0) {
    const std::string number = text.substr(prefix.size());
    size_t used = 0;
    double g = 0;
    try {
      g = std::stod(number, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == number.size() && used > 0) return TransferCurve::power(g);
  }
  throw std::invalid_argument("unknown --transfer '" + text +
                              "': use auto, linear, srgb or gamma:G (a power law, linear = code^G, G in [0.2, 5])");
}

TransferDecision decide_transfer(const std::optional<TransferCurve>& forced, const ColourTag& tag,
                                 bool integer_format, int bits_per_sample) {
  if (forced) return {*forced, "forced by " + forced->option(), false};
  if (tag.present) return {tag.curve, tag.source, false};
  if (integer_format && bits_per_sample <= 8)
    return {TransferCurve::srgb(), fmt::format("{}-bit, no colour tag", bits_per_sample), true};
  if (integer_format) return {TransferCurve::linear(), fmt::format("{}-bit, no colour tag", bits_per_sample), true};
  return {TransferCurve::linear(), "float, no colour tag", true};
}

}  // namespace tactres
