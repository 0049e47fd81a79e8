// find_fiducials (fiducials.h): the search over detection scales and modes,
// and which answer wins. The stages it runs are listed in
// fiducials_internal.h.

#include "tactres/locate/fiducials.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "fiducials_internal.h"
#include "finite_pixels.h"

namespace tactres {

using namespace locate_detail;

void FiducialSearchOptions::validate() const {
  if (!(min_radius_px > 1.0 && min_radius_px <= 1000.0))
    throw std::invalid_argument(
        fmt::format("fiducial min_radius_px must be in (1, 1000] px, got {}", min_radius_px));
  if (!(max_tilt_deg >= 0.0 && max_tilt_deg <= 80.0))
    throw std::invalid_argument(
        fmt::format("fiducial max_tilt_deg must be in [0, 80] degrees, got {}", max_tilt_deg));
  if (!(max_area_ratio >= 1.5 && max_area_ratio <= 100.0))
    throw std::invalid_argument(
        fmt::format("fiducial max_area_ratio must be in [1.5, 100], got {}", max_area_ratio));
  if (!(max_fit_error_frac > 0.0 && max_fit_error_frac <= 0.2))
    throw std::invalid_argument(
        fmt::format("fiducial max_fit_error_frac must be in (0, 0.2], got {}", max_fit_error_frac));
  if (max_candidates < 5 || max_candidates > 1000)
    throw std::invalid_argument(
        fmt::format("fiducial max_candidates must be in [5, 1000], got {}", max_candidates));
}

namespace {

std::string missing_names(const Pattern& pat, const std::array<int, 5>& cand) {
  std::string s;
  for (int k = 0; k < 5; ++k)
    if (cand[k] < 0) s += (s.empty() ? "" : ", ") + pat.id[k];
  return s;
}

// The detection scales, coarse first (fast): a 2x-downsampled copy keeps
// discs of >= 5 px radius detectable. Full resolution only if the coarse
// pass finds no full set.
std::vector<int> detection_scales(const cv::Mat& luminance, const FiducialSearchOptions& options) {
  std::vector<int> scales;
  if (std::min(luminance.cols, luminance.rows) >= 400) scales.push_back(2);
  if (scales.empty() || !options.coarse_only) scales.push_back(1);
  return scales;
}

// The luminance at one detection scale (a per-thread buffer when scaled).
cv::Mat detection_image(const cv::Mat& luminance, int scale) {
  if (scale == 1) return luminance;
  cv::resize(luminance, workspace().img,
             cv::Size(luminance.cols / scale, luminance.rows / scale), 0, 0, cv::INTER_AREA);
  return workspace().img;
}

// The discs of an identified verdict as found in mode `pol`.
FiducialSearchResult found_result(const Verdict& v, int pol, const std::vector<Blob>& blobs,
                                  RefinedCache& refined, const Pattern& pat) {
  FiducialSearchResult r;
  r.found = true;
  r.dark_on_light = pol == kDark;
  r.shaded = pol == kShaded;
  r.candidates = static_cast<int>(blobs.size());
  r.image_from_target = v.H;
  r.fit_rms_px = v.rms_px;
  for (int k = 0; k < 5; ++k) {
    const int b = v.cand[k];
    if (b < 0) continue;
    const Refined* f = refined.get(b);  // verified, so refined
    r.discs.push_back(
        {pat.id[k], f->centroid, f->area, blobs[b].axis_ratio, blobs[b].residual, f->contrast});
  }
  if (v.n == 4)
    r.warning = fmt::format(
        "only 4 of the 5 fiducial discs were found ({} is hidden, out of view or unusable): "
        "the pose rests on 4 discs; frame the whole target for a better fit",
        missing_names(pat, v.cand));
  return r;
}

// The search's best answer so far, and what the failures said.
struct SearchState {
  FiducialSearchResult best;
  int best_partial = 0;
  bool any_ambiguous = false;
  double best_score = kInf;
  int best_pol = -1;
  // The best answer's discs are crescents taken for printed discs or rings
  // (Verdict::bipolar): every other mode, at every scale, may still replace
  // it.
  bool best_bipolar = false;

  // A settled answer: found, and no relief's crescents.
  bool settled() const { return best.found && !best_bipolar; }

  // Prefer discs that are no relief's crescents (the shaded mode's are
  // fitted to both crescents), then more discs, then the better fit.
  bool improves(const Verdict& v) const {
    if (!best.found) return true;
    if (v.bipolar && !best_bipolar) return false;
    return !(v.bipolar == best_bipolar &&
             (v.n < static_cast<int>(best.discs.size()) ||
              (v.n == static_cast<int>(best.discs.size()) && v.score >= best_score)));
  }
};

// Searches one detection scale, mode by mode in `pol_order`, updating `st`.
// True when the answer is final (all five discs, no crescents).
bool search_scale(const cv::Mat& luminance, int scale, const std::array<int, 3>& pol_order,
                  const Pattern& pat, const FiducialSearchOptions& options, SearchState& st) {
  const cv::Mat img = detection_image(luminance, scale);
  std::optional<Normalised> nz;
  std::optional<ReliefMask> relief;
  Detection det;
  det.scale = scale;
  for (int pol : pol_order) {
    // Four discs found in one mode: only that mode may show the fifth
    // (e.g. at full resolution).
    if (st.settled() && pol != st.best_pol) continue;
    if (pol == kShaded) {
      if (!relief) relief = relief_mask(img);
    } else if (!nz) {
      nz = normalise(img);
    }
    static const Normalised kNone;
    static const ReliefMask kNoRelief;
    detect_mode(nz ? *nz : kNone, relief ? *relief : kNoRelief, pol, options, pat.disc_per_spread,
                det);
    const auto& blobs = det.blobs[pol];
    RefinedCache refined(luminance, det, pol);
    const Identification id = identify(blobs, pat, options, refined, pol == kShaded);
    st.best_partial = std::max(st.best_partial, id.partial_count);
    st.any_ambiguous = st.any_ambiguous || id.ambiguous;
    const Verdict& v = id.verdict;
    if (!v.ok || !st.improves(v)) continue;
    st.best = found_result(v, pol, blobs, refined, pat);
    st.best_score = v.score;
    st.best_pol = pol;
    st.best_bipolar = v.bipolar;
    if (v.n == 5 && !st.best_bipolar) return true;
  }
  return false;
}

// Four discs found at this scale: the missing disc's area is within
// max_area_ratio of the found ones'; if even the smallest such disc would
// have been seen at this scale, a finer one will not find it either.
bool finer_scale_is_futile(const FiducialSearchResult& best, const FiducialSearchOptions& options,
                           int scale) {
  double r_min_found = kInf;
  for (const auto& d : best.discs) r_min_found = std::min(r_min_found, std::sqrt(d.area_px / kPi));
  const double r_detectable = std::max(options.min_radius_px, 2.5 * scale);
  return r_min_found / std::sqrt(options.max_area_ratio) >= r_detectable;
}

// The answer when the search found no usable pattern: why, as a user can act on it.
FiducialSearchResult not_found(const SearchState& st, bool layout_dark) {
  FiducialSearchResult r;
  r.dark_on_light = layout_dark;
  if (st.best.found) {
    // Five crescents of a relief fit the pattern as filled discs, but no
    // mode fitted the discs themselves: their centroids would be up to a
    // radius off, and the pose with them. Refused rather than reported.
    r.problem =
        "the fiducial discs show as a relief's light and dark crescents, too small or blurred to fit "
        "their rims (only the crescents themselves were found, up to a disc radius off the discs' "
        "centres): capture the target larger or sharper";
  } else if (st.best_partial >= 5) {
    r.problem =
        "five discs match the fiducial pattern, but the rest of the capture does not match layout.json "
        "(the reference patch is not where the layout puts it): measure with the layout of the captured "
        "target";
  } else if (st.best_partial >= 3 || st.any_ambiguous) {
    r.problem = fmt::format(
        "found {} of the 5 fiducial discs{}: the target is partly out of view or occluded; frame "
        "the whole target",
        st.best_partial, st.any_ambiguous ? " but cannot tell which is which without the fifth" : "");
  } else {
    r.problem =
        "no target found: none of the blobs form the 5-disc fiducial pattern of layout.json (is "
        "this the right layout? is the target in view and in focus?)";
  }
  return r;
}

}  // namespace

FiducialSearchResult find_fiducials(const cv::Mat& luminance, const TargetLayout& layout,
                                    const FiducialSearchOptions& options) {
  options.validate();
  if (luminance.empty() || luminance.type() != CV_32FC1)
    throw std::invalid_argument(
        "find_fiducials needs a non-empty single-channel float (CV_32FC1) luminance image");
  if (!all_finite(luminance))
    throw std::invalid_argument(
        "find_fiducials got non-finite pixels: apply the loader's non-finite policy first");
  const Pattern pat = make_pattern(layout);
  // The coarse pass's buffers (a quarter of the pixels; the padded mask of
  // detect_mode a little more) stay for the next call; larger ones go.
  struct TrimWorkspace {
    size_t keep;
    ~TrimWorkspace() { workspace().trim(keep); }
  } trim{std::max<size_t>(luminance.total() * 3 / 10, size_t{1} << 18)};

  const bool layout_dark = layout.polarity == Polarity::dark_bars_on_light;
  // The layout's polarity first; shaded (a relief through a gel: crescents
  // or rings) last, as it is the least selective.
  const std::array<int, 3> pol_order = layout_dark ? std::array<int, 3>{kDark, kLight, kShaded}
                                                   : std::array<int, 3>{kLight, kDark, kShaded};
  SearchState st;
  // Scale by scale, every mode on the coarse copy first: whichever way the
  // discs show, they are usually found there in a few ms, and the costly
  // full-resolution passes run only for small discs or none found.
  for (int scale : detection_scales(luminance, options)) {
    if (search_scale(luminance, scale, pol_order, pat, options, st)) return st.best;
    if (st.settled() && finer_scale_is_futile(st.best, options, scale)) return st.best;
  }
  if (st.settled()) return st.best;
  return not_found(st, layout_dark);
}

}  // namespace tactres
