#include "common/running_stats.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace ragdoll {

void RunningStats::Update(const float* batch, int64_t rows) {
  if (rows <= 0) return;
  const size_t size = mean_.size();
  const double n_b = static_cast<double>(rows);
  std::vector<double> mean_b(size), m2_b(size);
  for (size_t j = 0; j < size; ++j) {
    // Two passes over the batch: its mean, then its spread about that mean, which avoids the
    // cancellation of sum(x^2) - n * mean^2 when the mean is large against the spread.
    double sum = 0.0;
    for (int64_t i = 0; i < rows; ++i)
      sum += static_cast<double>(batch[static_cast<size_t>(i) * size + j]);
    mean_b[j] = sum / n_b;
    double m2 = 0.0;
    for (int64_t i = 0; i < rows; ++i) {
      const double d = static_cast<double>(batch[static_cast<size_t>(i) * size + j]) - mean_b[j];
      m2 += d * d;
    }
    m2_b[j] = m2;
  }
  Merge(n_b, mean_b, m2_b);
}

void RunningStats::Merge(double count, const std::vector<double>& mean,
                         const std::vector<double>& m2) {
  if (count <= 0) return;
  if (mean.size() != mean_.size() || m2.size() != mean_.size()) {
    throw std::invalid_argument("RunningStats::Merge: sizes differ");
  }
  const double n = count_ + count;
  for (size_t j = 0; j < mean_.size(); ++j) {
    // Chan, Golub and LeVeque (1979): the combined sum of squared deviations is the two parts'
    // plus the spread between their means.
    const double delta = mean[j] - mean_[j];
    const double combined = var_[j] * count_ + m2[j] + delta * delta * count_ * count / n;
    mean_[j] += delta * count / n;
    var_[j] = combined / n;
  }
  count_ = n;
}

void RunningStats::Normalize(const float* in, int64_t rows, float* out, double clip,
                             double epsilon) const {
  const size_t size = mean_.size();
  std::vector<double> inv_std(size);
  for (size_t j = 0; j < size; ++j) inv_std[j] = 1.0 / std::sqrt(var_[j] + epsilon);
  for (int64_t i = 0; i < rows; ++i) {
    for (size_t j = 0; j < size; ++j) {
      const size_t k = static_cast<size_t>(i) * size + j;
      const double z = (static_cast<double>(in[k]) - mean_[j]) * inv_std[j];
      out[k] = static_cast<float>(std::clamp(z, -clip, clip));
    }
  }
}

}  // namespace ragdoll
