#pragma once
// Private to locate: whether one hypothesis (which blob is which layout
// disc) holds, from what the plane map it implies predicts: every disc's
// centroid, image area and shape, the collinear triple, and for printed
// targets ink where the reference patch should be (fiducials.h). Used by
// the search in fiducial_identify.cpp.

#include <array>
#include <optional>
#include <vector>

#include "fiducials_internal.h"

namespace tactres::locate_detail {

// Least-squares affine map (>= 3 points, not all collinear) as a homography.
std::optional<Homography> fit_affine(const std::vector<Vec2>& src, const std::vector<Vec2>& dst);

// What hypotheses are made of (one mode's blobs, refined on demand) and
// checked against (the pattern, the options): shared by the search
// (fiducial_identify.cpp) and the check below.
class HypothesisContext {
 protected:
  HypothesisContext(const std::vector<Blob>& blobs, const Pattern& pat,
                    const FiducialSearchOptions& o, RefinedCache& refined, bool shaded)
      : blobs_(blobs),
        pat_(pat),
        o_(o),
        refined_(refined),
        shaded_(shaded),
        cos_tilt_(std::cos(o.max_tilt_deg * kPi / 180)) {}

  const std::vector<Blob>& blobs_;
  const Pattern& pat_;
  const FiducialSearchOptions& o_;
  RefinedCache& refined_;
  bool shaded_;  // relief discs: outlines are rough, the rim fit is what counts
  double cos_tilt_;
};

class HypothesisCheck : private HypothesisContext {
 public:
  HypothesisCheck(const std::vector<Blob>& blobs, const Pattern& pat,
                  const FiducialSearchOptions& o, RefinedCache& refined, bool shaded)
      : HypothesisContext(blobs, pat, o, refined, shaded) {}

  // 4 or 5 discs (cand: blob index per layout disc, -1 where missing): ok
  // with the best-scoring map, or `seen` when the discs fit but the
  // reference patch is not where the map puts it.
  Verdict verify(const std::array<int, 5>& cand);
  // Three discs (for the message only).
  Verdict verify3(const std::array<int, 5>& cand);

 private:
  std::optional<double> relief_shape_score(const std::array<Sym2, 5>& P,
                                           const std::array<int, 5>& cand, bool strict) const;
  std::optional<double> ring_score(const std::array<Sym2, 5>& P, const std::array<int, 5>& cand,
                                   int n, bool strict) const;
  std::optional<double> shape_score(const Homography& H, const std::array<int, 5>& cand,
                                    bool strict, bool& printed) const;
  bool patch_ok(const Homography& H, const std::array<int, 5>& cand) const;
  bool in_front(const Homography& H) const;
  bool rough_fit_hopeless(const std::vector<Vec2>& src, const std::array<int, 5>& cand,
                          double amax) const;
  std::vector<Homography> candidate_maps(const std::vector<Vec2>& src,
                                         const std::vector<Vec2>& dst, int missing) const;
};

}  // namespace tactres::locate_detail
