// Running mean and variance of observations: owned and updated by the learner, shipped in every
// policy snapshot, applied identically by actors and evaluation tools. Pure C++ (no torch), so
// the actor and the tests share the exact arithmetic.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <utility>
#include <vector>

namespace ragdoll {

class RunningStats {
 public:
  RunningStats() = default;
  explicit RunningStats(int size) : mean_(size, 0.0), var_(size, 1.0) {}
  RunningStats(std::vector<double> mean, std::vector<double> var, double count)
      : mean_(std::move(mean)), var_(std::move(var)), count_(count) {
    if (mean_.size() != var_.size()) throw std::invalid_argument("mean and var sizes differ");
  }

  int size() const { return static_cast<int>(mean_.size()); }
  const std::vector<double>& mean() const { return mean_; }
  // Population variance (divided by count).
  const std::vector<double>& var() const { return var_; }
  double count() const { return count_; }

  // A batch's own moments: per-column mean and m2 (the sum of squared deviations from that
  // mean) of `rows` rows of `size` ([rows, size], row-major); zeros when there are no rows.
  struct Moments {
    std::vector<double> mean, m2;
  };
  static Moments BatchMoments(const float* batch, int64_t rows, int size);

  // Merges a batch of `rows` observations ([rows, size()], row-major) with Chan et al.'s
  // parallel update, so the result equals the statistics of everything seen as one batch.
  void Update(const float* batch, int64_t rows);
  // Merges a batch given by its moments: `count` rows, per-column `mean` and `m2` (the sum of
  // squared deviations from that mean). Learner replicas merge their batches' moments first, so
  // every replica ends with the statistics of the union.
  void Merge(double count, const std::vector<double>& mean, const std::vector<double>& m2);

  // (x - mean) / sqrt(var + epsilon), clipped to [-clip, clip]; `rows` rows of size().
  void Normalize(const float* in, int64_t rows, float* out, double clip = 10.0,
                 double epsilon = 1e-8) const;

 private:
  std::vector<double> mean_;
  std::vector<double> var_;
  double count_ = 0;
};

}  // namespace ragdoll
