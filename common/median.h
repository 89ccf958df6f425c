// The median of repeated measurements, as the benchmarks report them (noisy machines: medians,
// not means).
#pragma once

#include <algorithm>
#include <stdexcept>
#include <vector>

namespace ragdoll {

// The middle value; the mean of the two middle values for an even count.
inline double Median(std::vector<double> values) {
  if (values.empty()) throw std::invalid_argument("median of no values");
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

}  // namespace ragdoll
