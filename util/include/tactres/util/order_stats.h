#pragma once
// Order statistics and moments of samples (timings for the bench and the
// benchmarks; repeated estimates of one quantity).

#include <algorithm>
#include <cmath>
#include <vector>

namespace tactres {

// Percentile with linear interpolation between order statistics (the
// "type 7" definition of R and NumPy's default). `v` must not be empty.
inline double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  const double x = p * double(v.size() - 1);
  const size_t i = size_t(x);
  if (i + 1 >= v.size()) return v.back();
  return v[i] + (x - double(i)) * (v[i + 1] - v[i]);
}
inline double median(const std::vector<double>& v) { return v.empty() ? 0.0 : percentile(v, 0.5); }
inline double mean(const std::vector<double>& v) {
  double sum = 0;
  for (double x : v) sum += x;
  return v.empty() ? 0.0 : sum / double(v.size());
}
// The sample standard deviation (n - 1 in the denominator); 0 for fewer
// than two values.
inline double sample_sd(const std::vector<double>& v) {
  if (v.size() < 2) return 0.0;
  const double m = mean(v);
  double ss = 0;
  for (double x : v) ss += (x - m) * (x - m);
  return std::sqrt(ss / double(v.size() - 1));
}

}  // namespace tactres
