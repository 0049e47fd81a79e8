#include "tactres/measure/measurement.h"

#include <algorithm>
#include <stdexcept>

namespace tactres {

const char* to_string(ElementStatus s) {
  switch (s) {
    case ElementStatus::ok: return "ok";
    case ElementStatus::low_signal: return "low_signal";
    case ElementStatus::clipped: return "clipped";
    case ElementStatus::aliased: return "aliased";
    case ElementStatus::below_sampling_limit: return "below_sampling_limit";
    case ElementStatus::out_of_view: return "out_of_view";
    case ElementStatus::fit_failed: return "fit_failed";
    case ElementStatus::damaged: return "damaged";
  }
  return "fit_failed";
}

const char* to_string(Preset p) {
  return p == Preset::fast ? "fast" : p == Preset::balanced ? "balanced" : "precise";
}

Preset preset_from_string(const std::string& s) {
  if (s == "fast") return Preset::fast;
  if (s == "balanced") return Preset::balanced;
  if (s == "precise") return Preset::precise;
  throw std::invalid_argument("unknown preset '" + s + "': use fast, balanced or precise");
}

MeasureOptions MeasureOptions::for_preset(Preset p) {
  // What each preset buys (README, "Presets"; figures from `tactres bench`):
  // fast: whole-pixel bins and a light pose model, still fitting the PSF's
  // shape (a Gaussian-only fit cost little time but its errors were three
  // times larger and its error bars covered the truth half the time);
  // precise: eighth-pixel bins and a finely sampled disc outline in the pose
  // model.
  struct Settings {
    double bin_px;
    bool fit_psf_shape;
    int pose_boundary_points;
    double max_bins_per_bar;
  };
  static constexpr Settings kSettings[] = {
      {1.0, true, 16, 6},      // fast
      {0.25, true, 32, 8},     // balanced
      {0.125, true, 96, 16},   // precise
  };
  const Settings& s = kSettings[static_cast<int>(p)];
  MeasureOptions o;
  o.preset = p;
  o.sampling.bin_px = s.bin_px;
  o.fit_psf_shape = s.fit_psf_shape;
  o.pose_boundary_points = s.pose_boundary_points;
  o.max_bins_per_bar = s.max_bins_per_bar;
  return o;
}

double MeasureOptions::bin_px_for(double px_per_bar) const {
  return std::min(std::max(sampling.bin_px, px_per_bar / max_bins_per_bar), 0.5 * px_per_bar);
}

void MeasureOptions::validate() const {
  sampling.validate();
  criterion.validate();
  detectability.validate();
  if (!(min_px_per_bar >= 0.5 && min_px_per_bar <= 20))
    throw std::invalid_argument("--min-px-per-bar must be in [0.5, 20]");
  if (!(max_m_sigma > 0 && max_m_sigma <= 1)) throw std::invalid_argument("max m sigma must be in (0, 1]");
  if (!(aliasing_chi2 > 1)) throw std::invalid_argument("aliasing chi^2 threshold must be > 1");
  if (!(pose_boundary_points >= 8 && pose_boundary_points <= 1024))
    throw std::invalid_argument("pose boundary points must be in [8, 1024]");
  if (!(max_bins_per_bar >= 2 && max_bins_per_bar <= 64))
    throw std::invalid_argument("max bins per bar must be in [2, 64]");
  if (signature != "auto" && signature != "albedo" && signature != "shading")
    throw std::invalid_argument("--signature must be auto, albedo or shading");
}

}  // namespace tactres
