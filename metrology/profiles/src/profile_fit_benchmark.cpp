// Profile-fit benchmark (not a test): the time of one fit_profile on a
// typical element profile, the unit that every measurement repeats 30-120
// times. Three Gaussian-blurred bars with noise, at the bin counts the
// presets give (fast: w/6 bins on coarse elements, 1 px on fine ones;
// balanced: w/8 and 1/4 px), cold start and warm start (the previous
// element's or frame's fit as the start, as grade_jobs and live mode do).
// Run: ./build/metrology/profiles/tactres_profile_fit_benchmark [FITS]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>

#include "tactres/profiles/profile_fit.h"

using namespace tactres;

namespace {

// Three bars of width w_mm at -2w, 0, 2w blurred by a Gaussian of sd s_mm,
// sampled in `bins` bins over +-8 w with noise; the central +-4.5 w is fitted.
ProfileData blurred_triplet(double w_mm, double s_mm, int bins, double noise_sd, std::mt19937_64& rng) {
  ProfileData d;
  d.bin_count = bins;
  d.bin_mm = 16 * w_mm / bins;
  d.u0_mm = -8 * w_mm;
  for (int k = -1; k <= 1; ++k) d.ideal.push_back({(2 * k - 0.5) * w_mm, (2 * k + 0.5) * w_mm, 1.0});
  std::normal_distribution<double> noise(0.0, noise_sd);
  auto cdf = [](double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); };
  for (int i = 0; i < bins; ++i) {
    const double u = d.bin_center_mm(i);
    double cover = 0;
    for (const IdealBox& b : d.ideal) cover += cdf((b.u1_mm - u) / s_mm) - cdf((b.u0_mm - u) / s_mm);
    d.value.push_back(0.6 * (1 - 0.7 * cover) + noise(rng));
    d.u_mean_mm.push_back(u);
    d.sigma.push_back(noise_sd);
    d.count.push_back(8);
  }
  d.fit_begin = bins * 7 / 32;
  d.fit_end = bins - d.fit_begin;
  return d;
}

void run(const char* what, int bins, bool warm, int fits) {
  std::mt19937_64 rng(7);
  const double w_mm = 0.05, s_mm = 0.6 * w_mm;
  ProfileFitOptions o;
  o.contrast = -0.7;
  if (warm) {
    o.start_nu0_per_mm = 1 / (2 * M_PI * s_mm * std::sqrt(0.5)) * 1.05;  // near the truth
    o.start_beta = 2.1;
  }
  const ProfileData d = blurred_triplet(w_mm, s_mm, bins, 0.004, rng);
  // The fastest of five batches: a shared machine's noise only ever adds time.
  double sink = 0, us = 1e300;
  for (int batch = 0; batch < 5; ++batch) {
    const auto t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < fits / 5; ++k) sink += fit_profile(d, o).nu0_per_mm;
    us = std::min(us, std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count() / (fits / 5));
  }
  const ProfileFit last = fit_profile(d, o);
  std::printf("  %-34s %3d bins  %7.1f us/fit   (%s)%s\n", what, bins, us, last.solver_report.c_str(),
              sink > 0 ? "" : " (no fit)");
}

}  // namespace

int main(int argc, char** argv) {
  const int fits = argc > 1 ? std::max(10, std::atoi(argv[1])) : 2000;
  std::printf("tactres profile-fit benchmark: one fit_profile, the fastest of 5 batches of %d fits, one thread\n", fits / 5);
  run("fast, coarse element (w/6 bins)", 96, false, fits);
  run("fast, fine element (1 px bins)", 32, false, fits);
  run("balanced, coarse element (w/8)", 128, false, fits);
  run("balanced, fine element (1/4 px)", 64, false, fits);
  run("fast, coarse element, warm start", 96, true, fits);
  run("balanced, coarse, warm start", 128, true, fits);
  return 0;
}
