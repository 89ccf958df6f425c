#include "common/running_stats.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace ragdoll {

RunningStats::Moments RunningStats::BatchMoments(const float* batch, int64_t rows, int size) {
  const size_t n = static_cast<size_t>(std::max(size, 0));
  Moments m{std::vector<double>(n, 0.0), std::vector<double>(n, 0.0)};
  if (rows <= 0) return m;
  // Two passes over the batch: its mean, then its spread about that mean, which avoids the
  // cancellation of sum(x^2) - n * mean^2 when the mean is large against the spread. Row by
  // row, so memory is read in order; each column still sums its rows first to last.
  for (int64_t i = 0; i < rows; ++i) {
    const float* row = batch + static_cast<size_t>(i) * n;
    for (size_t j = 0; j < n; ++j) m.mean[j] += static_cast<double>(row[j]);
  }
  for (double& x : m.mean) x /= static_cast<double>(rows);
  for (int64_t i = 0; i < rows; ++i) {
    const float* row = batch + static_cast<size_t>(i) * n;
    for (size_t j = 0; j < n; ++j) {
      const double d = static_cast<double>(row[j]) - m.mean[j];
      m.m2[j] += d * d;
    }
  }
  return m;
}

void RunningStats::Update(const float* batch, int64_t rows) {
  if (rows <= 0) return;
  Moments m = BatchMoments(batch, rows, size());
  Merge(static_cast<double>(rows), m.mean, m.m2);
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
