#include "tactres/profiles/gap_dips.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "tactres/profiles/profile_sampler.h"

namespace tactres {

namespace {

// Half-width of the windows, in bar widths: the middle half of each bar
// and gap, where the edges' blur matters least.
constexpr double kWindowHalfBars = 0.25;
// The triplet's shift is searched over +-half a bar in this many steps a side.
constexpr int kShiftSteps = 10;

struct WindowMean {
  bool valid = false;
  double mean = 0, se = 0;
};

// The samples' mean over the bins whose mean u lies within the window, and
// its standard error. A clipped bin (ProfileData::bound) only bounds the
// light: it counts where that bound errs towards a shallower dip (`safe`,
// e.g. +1 for a bright bar clipped at saturation, which was at least that
// bright), and is left out otherwise (safe_bound 0: every clipped bin).
WindowMean window_mean(const ProfileData& d, double center_mm, double half_mm, int safe_bound) {
  double n = 0, sum = 0, var = 0;
  for (int b = d.fit_begin; b < d.fit_end; ++b) {
    const int bound = d.bound_at(b);
    if (d.count[b] <= 0 || (bound != 0 && bound != safe_bound) || !std::isfinite(d.value[b])) continue;
    if (std::abs(d.u_mean_mm[b] - center_mm) >= half_mm) continue;
    const double c = d.count[b];
    n += c;
    sum += c * d.value[b];
    var += c * c * d.sigma[b] * d.sigma[b];
  }
  if (n <= 0) return {};
  return {true, sum / n, std::sqrt(var) / n};
}

}  // namespace

std::optional<int> GapDips::flat_gap() const {
  if (!valid) return std::nullopt;
  for (int k = 0; k < 2; ++k) {
    // Flat: no dip within the noise, or one under a tenth of the other
    // gap's (a fixed share, whatever --threshold says: a gap a reader
    // does not see beside one that plainly dips). A JPEG's
    // smoothing shrinks the bins' errors, and a copy of dev_04 at q90 made
    // G6E6 H's first gap (flat at 1.3 sigma in the original) dip at 4.6
    // sigma, 5 % of the other: it was resolved, the limit four elements
    // finer.
    const bool flat = dip[k] < 2 * sigma[k] || dip[k] < kMinGapDipRatio * dip[1 - k];
    if (flat && dip[1 - k] > 5 * sigma[1 - k]) return k;
  }
  return std::nullopt;
}

bool GapDips::three_bars() const { return valid && dip[0] > 5 * sigma[0] && dip[1] > 5 * sigma[1]; }

namespace {

// The dips with the triplet moved by shift_mm.
GapDips dips_at(const ProfileData& d, const double bars_mm[3], double w, double half, double direction,
                double shift_mm) {
  GapDips out;
  WindowMean bar[3];
  for (int i = 0; i < 3; ++i) {
    bar[i] = window_mean(d, bars_mm[i] + shift_mm, half, direction > 0 ? 1 : -1);
    if (!bar[i].valid) return out;
  }
  for (int k = 0; k < 2; ++k) {
    const WindowMean gap = window_mean(d, 0.5 * (bars_mm[k] + bars_mm[k + 1]) + shift_mm, half, direction > 0 ? -1 : 1);
    if (!gap.valid) return out;
    const WindowMean& weaker = direction * (bar[k].mean - bar[k + 1].mean) < 0 ? bar[k] : bar[k + 1];
    out.dip[k] = direction * (weaker.mean - gap.mean);
    out.sigma[k] = std::hypot(weaker.se, gap.se);
  }
  // The ground beyond each outer bar, from its unclipped bins: a clipped
  // one only bounds it.
  double n = 0, sum = 0;
  for (const int side : {-1, 1}) {
    const WindowMean g = window_mean(d, bars_mm[side < 0 ? 0 : 2] + shift_mm + side * 1.5 * w, 0.5 * w, 0);
    if (g.valid) n += 1, sum += g.mean;
  }
  out.ground = n > 0 ? sum / n : 0;
  out.valid = true;
  return out;
}

}  // namespace

GapDips gap_dips(const ProfileData& d, double bar_width_mm, double contrast, double pixel_mm) {
  const double w = bar_width_mm;
  std::vector<double> bars;
  for (const IdealBox& b : d.ideal) {
    if (is_complement_box(d, b)) continue;
    const double c = 0.5 * (b.u0_mm + b.u1_mm), width = b.u1_mm - b.u0_mm;
    if (std::abs(c) < 3 * w && std::abs(width - w) < 0.2 * w) bars.push_back(c);
  }
  if (bars.size() != 3) return {};
  std::sort(bars.begin(), bars.end());
  // +1 where the bars lie above the gaps in the data.
  const double direction = contrast * (d.ideal_at(bars[1]) - d.ideal_at(0.5 * (bars[0] + bars[1]))) > 0 ? 1 : -1;
  // The windows go where the data put the triplet: within half a bar of the
  // ideal, the shift at which the two dips together are deepest. A pattern
  // placed a third of a bar off (a poor fit's shift) would otherwise read a
  // gap's edge as its middle; one shift for all five windows keeps a gap
  // that is flat from borrowing a dip.
  const double half = std::max(kWindowHalfBars * w, 0.5 * pixel_mm);
  GapDips best;
  for (int step = -kShiftSteps; step <= kShiftSteps; ++step) {
    const GapDips g = dips_at(d, bars.data(), w, half, direction, step * (0.5 * w / kShiftSteps));
    if (g.valid && (!best.valid || g.dip[0] + g.dip[1] > best.dip[0] + best.dip[1])) best = g;
  }
  return best;
}

}  // namespace tactres
