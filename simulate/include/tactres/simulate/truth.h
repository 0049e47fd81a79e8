#pragma once
// The true answer for a simulated capture ("tactres.truth/2"; /2 added the
// detectability limit and each element's true CNR).
//
// m(f) of the whole chain for every element. Where the chain is linear, it
// is the product of the effects' transfer functions at the element's
// frequency, mapped into the image through the local lens Jacobian:
//   gel      exp(-2 pi^2 sigma_gel^2 f^2)          (contact, relief targets)
//   optics   psf_mtf(|k_img|)                      (blur)
//   pixel    sinc(k_img,x) sinc(k_img,y)           (the pixel's own area)
// with k_img = J^-T k_target in cycles/px. Illumination and vignetting are
// slow multiplicative fields and zero-mean sensor noise leaves the mean
// unchanged, so they keep m. Full (non-linearised) Lambert shading is not
// linear: there m is computed numerically as the sine response of the
// shading at the relief's amplitude, relative to its small-signal response,
// and the element says "analytic": false.
//
// Detectability (profiles/detectability.h), when the scene has a sensor:
// each element's true Rose CNR from the scene's exposure and the EMVA 1288
// model at the element's centre: the signal is the bars' fundamental
// peak-to-peak in DN (true m, the level step the target and the lights give
// there, times illumination and vignetting), the noise the model's temporal
// sigma in DN at the element's mean level, the pixels those of one bar.
// Shading uses the linearised Lambert coefficients. Without a sensor the
// capture is noise-free: no CNR, and the reported limit is the optical one.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "tactres/camera/camera_model.h"
#include "tactres/profiles/criterion.h"
#include "tactres/profiles/detectability.h"
#include "tactres/simulate/scene.h"
#include "tactres/targets/layout.h"

namespace tactres {

inline constexpr const char* kTruthSchema = "tactres.truth/2";

struct TruthElement {
  int group = 0, element = 1;
  BarOrientation orientation = BarOrientation::horizontal_bars;
  double lp_per_mm = 0;
  double m = 0;
  bool analytic = true;
  double px_per_bar = 0;  // bar width in pixels across the bars
  Vec2 center_px;
  bool in_view = true;
  std::optional<double> cnr;  // absent without a sensor (noise-free)
  double shot_fraction = 0;   // share of the noise variance that is shot noise
};

struct Truth {
  std::vector<TruthElement> elements;
  Limit horizontal, vertical;  // reported: the coarser of the two parts
  LimitBreakdown horizontal_parts, vertical_parts;
  DetectabilityCriterion detectability;
  double nyquist_h_lp_per_mm = 0, nyquist_v_lp_per_mm = 0;  // at the target centre
  bool seen_from_behind = false;
};

// `detectability`: the Rose threshold k of the true detectability limit
// (its significance test is dropped: the truth is exact).
Truth compute_truth(const Scene& scene, const TargetLayout& layout, const CameraModel& camera,
                    const DetectabilityCriterion& detectability = {});

nlohmann::json truth_to_json(const Truth& truth, const Scene& scene, const std::string& image_name);

}  // namespace tactres
