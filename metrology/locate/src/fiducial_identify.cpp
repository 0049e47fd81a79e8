// Identification: which blobs are which layout disc, mirrored or not. The
// search seeds hypotheses by the collinear triple (complete patterns) or by
// pairs under a whitened similarity (partial ones); fiducial_verify.cpp
// checks each against the plane map it implies.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <set>
#include <utility>
#include <vector>

#include "fiducial_verify.h"
#include "fiducials_internal.h"

namespace tactres::locate_detail {

namespace {

// One number per hypothesis (12 bits per disc's blob index), so that each
// is checked once.
std::uint64_t key_of(const std::array<int, 5>& cand) {
  std::uint64_t k = 0;
  for (int c : cand) k = (k << 12) | static_cast<std::uint64_t>(c + 1);
  return k;
}

class Identifier : private HypothesisContext {
 public:
  Identifier(const std::vector<Blob>& blobs, const Pattern& pat, const FiducialSearchOptions& o,
             RefinedCache& refined, bool shaded)
      : HypothesisContext(blobs, pat, o, refined, shaded), check_(blobs, pat, o, refined, shaded) {}

  // Complete patterns, seeded by collinear triples: perspective cannot break
  // collinearity, so this holds at any tilt.
  Verdict search_complete() {
    Verdict best;
    const int N = static_cast<int>(blobs_.size());
    for (int i = 0; i < N; ++i)
      for (int j = i + 1; j < N; ++j) {
        if (!area_ok(i, j) || !spacing_ok(i, j, pat_.a, pat_.b)) continue;
        const Vec2 ci = blobs_[i].center, cj = blobs_[j].center;
        const double D = norm(cj - ci);
        for (int m = 0; m < N; ++m) {
          if (m == i || m == j || !area_ok(m, i) || !area_ok(m, j)) continue;
          const Vec2 v = blobs_[m].center - ci;
          const double t = dot(v, cj - ci) / (D * D);
          if (t < 0.05 || t > 0.95) continue;
          if (std::abs(cross(cj - ci, v)) / D > 0.04 * D + 2.0) continue;
          for (int orient = 0; orient < 2; ++orient)
            extend_triple(orient ? j : i, m, orient ? i : j, best);
        }
      }
    return best;
  }

  // Partial patterns, seeded by pairs under a whitened similarity: the mean
  // disc ellipse undoes the tilt to first order. Returns every acceptable
  // hypothesis with >= 4 discs; 3-disc ones only count for max_seen().
  std::vector<Verdict> search_partial() {
    std::vector<Verdict> out;
    const int N = static_cast<int>(blobs_.size());
    std::vector<Vec2> w(N);
    for (int i = 0; i < N; ++i)
      for (int j = i + 1; j < N; ++j) {
        if (!area_ok(i, j)) continue;
        const Sym2 Cm{0.5 * (blobs_[i].cov.xx + blobs_[j].cov.xx),
                      0.5 * (blobs_[i].cov.xy + blobs_[j].cov.xy),
                      0.5 * (blobs_[i].cov.yy + blobs_[j].cov.yy)};
        const Sym2 W = Cm.inv_sqrt();
        for (int k = 0; k < N; ++k) w[k] = W.mul(blobs_[k].center);
        const double dw = norm(w[j] - w[i]);
        for (int u = 0; u < 5; ++u)
          for (int v = 0; v < 5; ++v) {
            if (u == v) continue;
            // A disc of radius r has covariance r^2/4: whitened, its radius is 2.
            const double expected = 2.0 * norm(pat_.p[v] - pat_.p[u]) / pat_.r_mm;
            if (dw < 0.6 * expected || dw > 1.6 * expected) continue;
            for (int refl = 0; refl < 2; ++refl) grow_pair(i, j, u, v, refl == 1, w, out);
          }
      }
    return out;
  }

  // Most discs in any partial hypothesis that fit the pattern (for the
  // message when nothing was identified).
  int max_seen() const { return max_seen_; }

 private:
  bool area_ok(int i, int j) const {
    const double r = blobs_[i].area / blobs_[j].area;
    return r <= o_.max_area_ratio && r >= 1 / o_.max_area_ratio;
  }

  // Is the distance between blobs i and j, measured in the metric of their
  // own ellipses (which undoes the tilt), the distance between layout discs
  // u and v? A disc of radius r has covariance r^2/4, so in whitened units
  // its radius is 2. Perspective, blur and thresholds leave a factor ~1.6;
  // shaded outlines are rougher.
  bool spacing_ok(int i, int j, int u, int v) const {
    const Sym2& Ci = blobs_[i].cov;
    const Sym2& Cj = blobs_[j].cov;
    const Sym2 Cm{0.5 * (Ci.xx + Cj.xx), 0.5 * (Ci.xy + Cj.xy), 0.5 * (Ci.yy + Cj.yy)};
    const double dw = std::sqrt(Cm.inverse().quad(blobs_[j].center - blobs_[i].center));
    const double expected = 2.0 * norm(pat_.p[v] - pat_.p[u]) / pat_.r_mm;
    const double slack = shaded_ ? 2.2 : 1.6;
    return dw > expected / slack && dw < expected * slack;
  }

  // Similarity (complex) z = alpha * q + beta with q the (optionally
  // reflected) layout point.
  static std::pair<Vec2, Vec2> similarity(Vec2 q0, Vec2 q1, Vec2 z0, Vec2 z1) {
    const Vec2 dq = q1 - q0, dz = z1 - z0;
    const double den = dot(dq, dq);
    const Vec2 alpha{(dz.x * dq.x + dz.y * dq.y) / den, (dz.y * dq.x - dz.x * dq.y) / den};
    const Vec2 beta{z0.x - (alpha.x * q0.x - alpha.y * q0.y),
                    z0.y - (alpha.x * q0.y + alpha.y * q0.x)};
    return {alpha, beta};
  }
  static Vec2 sim_apply(const std::pair<Vec2, Vec2>& s, Vec2 q) {
    return {s.first.x * q.x - s.first.y * q.y + s.second.x,
            s.first.x * q.y + s.first.y * q.x + s.second.y};
  }

  void extend_triple(int A, int M, int B, Verdict& best) {
    const int N = static_cast<int>(blobs_.size());
    const Vec2 cA = blobs_[A].center, cB = blobs_[B].center;
    const double span = norm(cB - cA);
    // Where C can be, from the layout's distances alone: tilt shortens a
    // length by at most cos(tilt) relative to another; perspective adds some.
    const Vec2 ab = pat_.p[pat_.b] - pat_.p[pat_.a], ac = pat_.p[pat_.c] - pat_.p[pat_.a];
    const double r_ac = norm(ac) / pat_.ab_mm;
    const double off_ac = std::abs(cross(ab, ac)) / (pat_.ab_mm * pat_.ab_mm);
    for (int C = 0; C < N; ++C) {
      if (C == A || C == M || C == B || !area_ok(C, A) || !area_ok(C, B)) continue;
      const Vec2 v = blobs_[C].center - cA;
      const double r = norm(v) / span;
      if (r < 0.6 * cos_tilt_ * r_ac || r > 1.7 * r_ac / cos_tilt_) continue;
      if (std::abs(cross(cB - cA, v)) / (span * span) < 0.5 * cos_tilt_ * off_ac) continue;
      if (!spacing_ok(A, C, pat_.a, pat_.c) || !spacing_ok(B, C, pat_.b, pat_.c)) continue;
      const auto Aff =
          fit_affine({pat_.p[pat_.a], pat_.p[pat_.b], pat_.p[pat_.c]}, {cA, cB, blobs_[C].center});
      if (!Aff) continue;
      const Vec2 dpred = map_point(*Aff, pat_.p[pat_.d]);
      for (int D = 0; D < N; ++D) {
        if (D == A || D == M || D == B || D == C || !area_ok(D, A) || !area_ok(D, B) ||
            !area_ok(D, C))
          continue;
        if (norm(blobs_[D].center - dpred) > 0.5 * span) continue;
        if (!spacing_ok(A, D, pat_.a, pat_.d) || !spacing_ok(C, D, pat_.c, pat_.d)) continue;
        std::array<int, 5> cand{};
        cand[pat_.a] = A;
        cand[pat_.m] = M;
        cand[pat_.b] = B;
        cand[pat_.c] = C;
        cand[pat_.d] = D;
        const Verdict vd = check_.verify(cand);
        if (vd.ok && vd.score < best.score) best = vd;
      }
    }
  }

  void grow_pair(int i, int j, int u, int v, bool refl, const std::vector<Vec2>& w,
                 std::vector<Verdict>& out) {
    const int N = static_cast<int>(blobs_.size());
    auto q = [&](int k) { return Vec2{pat_.p[k].x, refl ? -pat_.p[k].y : pat_.p[k].y}; };
    const auto S = similarity(q(u), q(v), w[i], w[j]);
    const double tol = 0.15 * std::hypot(S.first.x, S.first.y) * pat_.ab_mm;
    std::array<int, 5> cand{-1, -1, -1, -1, -1};
    cand[u] = i;
    cand[v] = j;
    auto used = [&](int b) { return std::find(cand.begin(), cand.end(), b) != cand.end(); };
    for (int k = 0; k < 5; ++k) {
      if (cand[k] >= 0) continue;
      const Vec2 z = sim_apply(S, q(k));
      int bestb = -1;
      double bestd = tol * tol;
      for (int b = 0; b < N; ++b) {
        const Vec2 e = w[b] - z;
        const double d = dot(e, e);
        if (d >= bestd || used(b) || !area_ok(b, i) || !area_ok(b, j)) continue;
        bestd = d;
        bestb = b;
      }
      // A blob that cannot be measured (at the border, touching other ink)
      // counts as missing.
      if (bestb >= 0 && !refined_.get(bestb)) bestb = -1;
      cand[k] = bestb;
    }
    const int n =
        static_cast<int>(std::count_if(cand.begin(), cand.end(), [](int c) { return c >= 0; }));
    if (n < 3) return;
    if (!seen_.insert(key_of(cand)).second) return;
    if (n == 3) {
      const Verdict v3 = check_.verify3(cand);
      if (v3.ok || v3.seen) max_seen_ = std::max(max_seen_, 3);
      return;
    }
    const Verdict vd = check_.verify(cand);
    if (vd.ok) out.push_back(vd);
    if (vd.ok || vd.seen) max_seen_ = std::max(max_seen_, vd.n);
  }

  HypothesisCheck check_;
  std::set<std::uint64_t> seen_;
  int max_seen_ = 0;  // most discs of any hypothesis that fit the pattern
};

}  // namespace

Identification identify(const std::vector<Blob>& blobs, const Pattern& pat,
                        const FiducialSearchOptions& o, RefinedCache& refined, bool shaded) {
  Identification id;
  if (blobs.size() < 3) return id;
  Identifier ider(blobs, pat, o, refined, shaded);
  if (blobs.size() >= 5) {
    id.verdict = ider.search_complete();
    if (id.verdict.ok) return id;
  }
  std::vector<Verdict> partial = ider.search_partial();
  id.partial_count = ider.max_seen();
  if (partial.empty()) return id;
  std::sort(partial.begin(), partial.end(), [](const Verdict& x, const Verdict& y) {
    return x.n != y.n ? x.n > y.n : x.score < y.score;
  });
  const Verdict& best = partial.front();
  if (best.n == 5) {
    id.verdict = best;
    return id;
  }
  // Shaded outlines say too little about each disc to trust four, nor do
  // four crescents taken for printed discs.
  if (shaded || best.bipolar) {
    id.partial_count = 4;
    return id;
  }
  // Four discs: accept only if every acceptable hypothesis names the same
  // discs the same way (e.g. with T3 hidden and no reference patch to look
  // at, the four corners fit under each symmetry of the rectangle).
  id.partial_count = 4;
  for (const Verdict& v : partial)
    if (v.cand != best.cand) {
      id.ambiguous = true;
      return id;
    }
  id.verdict = best;
  return id;
}

}  // namespace tactres::locate_detail
