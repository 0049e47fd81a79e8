#include "censored_level.h"

#include <cmath>

#include "tactres/util/order_stats.h"

namespace tactres::profiles_detail {

namespace {

// The bin in Olsen's parameters (Econometrica 46, 1978: the Tobit
// likelihood is concave in them, so Newton's method finds its one
// maximum): delta = level / spread, h = 1 / spread, for pixels y in units
// of s0 with the clip at 0. From the unclipped pixels' count n, sums S1 =
// sum y and S2 = sum y^2, and the clipped count k:
//   l = n log h - (h^2 S2 - 2 h delta S1 + n delta^2) / 2 + k log Phi(-delta).
// (A Ceres solve per bin cost 20 us: hundreds of bins per frame on a dark
// negative chart; this costs a few Newton steps on five numbers.)
struct Tobit {
  double n = 0, s1 = 0, s2 = 0, k = 0;
  double log_likelihood(double delta, double h) const {
    const double Phi = 0.5 * std::erfc(delta / std::sqrt(2.0));
    return n * std::log(h) - 0.5 * (h * h * s2 - 2 * h * delta * s1 + n * delta * delta) +
           (k > 0 ? k * std::log(Phi) : 0.0);
  }
  // The inverse Mills ratio phi(t) / Phi(t) at t = -delta, and the
  // censored pixels' curvature factor lambda (t + lambda), in (0, 1).
  void mills(double delta, double& lambda, double& curvature) const {
    const double t = -delta;
    const double Phi = 0.5 * std::erfc(-t / std::sqrt(2.0));
    const double phi = std::exp(-0.5 * t * t) / std::sqrt(2 * M_PI);
    lambda = Phi > 1e-300 ? phi / Phi : -t;  // its asymptote for a level far above black
    curvature = lambda * (t + lambda);
  }
  // Gradient g and the negative Hessian (the observed information) J, in
  // the order (delta, h).
  void derivatives(double delta, double h, double g[2], double J[3]) const {
    double lambda = 0, curvature = 0;
    mills(delta, lambda, curvature);
    g[0] = h * s1 - n * delta - k * lambda;
    g[1] = n / h - (h * s2 - delta * s1);
    J[0] = n + k * curvature;  // d2/d delta2
    J[1] = -s1;                // d2/d delta dh
    J[2] = n / (h * h) + s2;   // d2/dh2
  }
};

}  // namespace

std::optional<CensoredLevel> level_clipped_at_black(const std::vector<double>& values) {
  std::vector<double> unclipped;
  for (double v : values)
    if (v > 0) unclipped.push_back(v);
  if (static_cast<int>(unclipped.size()) < kMinUnclippedPixels) return std::nullopt;
  const double x0 = median(values), s0 = sample_sd(unclipped);
  if (!(s0 > 0) || !std::isfinite(x0)) return std::nullopt;
  Tobit L;
  L.k = static_cast<double>(values.size() - unclipped.size());
  for (double v : unclipped) {
    const double y = v / s0;
    L.n += 1, L.s1 += y, L.s2 += y * y;
  }
  double delta = x0 / s0, h = 1;
  bool converged = false;
  for (int it = 0; it < 50 && !converged; ++it) {
    double g[2], J[3];
    L.derivatives(delta, h, g, J);
    const double det = J[0] * J[2] - J[1] * J[1];
    if (!(det > 0)) return std::nullopt;
    const double step_delta = (J[2] * g[0] - J[1] * g[1]) / det, step_h = (J[0] * g[1] - J[1] * g[0]) / det;
    // Converged when the Newton decrement (the likelihood still to gain, x2)
    // is at rounding level.
    if (g[0] * step_delta + g[1] * step_h < 1e-12 * (1 + L.n + L.k)) {
      converged = true;
      break;
    }
    // Halved until the likelihood rises and h stays positive.
    const double before = L.log_likelihood(delta, h);
    double t = 1;
    while (t > 1e-6 && !(h + t * step_h > 0 && L.log_likelihood(delta + t * step_delta, h + t * step_h) > before))
      t *= 0.5;
    if (t <= 1e-6) return std::nullopt;
    delta += t * step_delta, h += t * step_h;
  }
  if (!converged) return std::nullopt;
  // The level mu = delta / h (in s0): its variance by the delta method from
  // the inverse information, both parameters free.
  double g[2], J[3];
  L.derivatives(delta, h, g, J);
  const double det = J[0] * J[2] - J[1] * J[1];
  const double d_delta = 1 / h, d_h = -delta / (h * h);
  const double var = (J[2] * d_delta * d_delta - 2 * J[1] * d_delta * d_h + J[0] * d_h * d_h) / det;
  const double mu = s0 * delta / h, spread = s0 / h;
  if (!(det > 0) || !std::isfinite(mu) || !(var > 0) || !std::isfinite(var)) return std::nullopt;
  return CensoredLevel{mu, s0 * std::sqrt(var), spread};
}

}  // namespace tactres::profiles_detail
