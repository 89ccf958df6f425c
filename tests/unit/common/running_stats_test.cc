#include "common/running_stats.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace ragdoll {
namespace {

// Mean and population variance of each column of a [rows, size] row-major array, directly:
// two passes in long double.
void DirectStats(const std::vector<float>& data, int size, std::vector<double>* mean,
                 std::vector<double>* var) {
  const size_t rows = data.size() / static_cast<size_t>(size);
  mean->assign(size, 0.0);
  var->assign(size, 0.0);
  for (int j = 0; j < size; ++j) {
    long double sum = 0;
    for (size_t i = 0; i < rows; ++i) sum += data[i * size + j];
    const long double m = sum / rows;
    long double ss = 0;
    for (size_t i = 0; i < rows; ++i) ss += (data[i * size + j] - m) * (data[i * size + j] - m);
    (*mean)[j] = static_cast<double>(m);
    (*var)[j] = static_cast<double>(ss / rows);
  }
}

TEST(RunningStats, MergingBatchesOfDifferentSizesEqualsOneBatch) {
  const int kSize = 3;
  // Columns far from zero relative to their spread, where a naive sum of squares loses digits.
  const std::vector<float> offset = {1000.0f, -3.0f, 0.0f};
  const std::vector<float> scale = {0.5f, 2.0f, 1e-3f};
  std::mt19937 rng(7);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  std::vector<float> all;
  RunningStats stats(kSize);
  for (int rows : {1, 7, 100}) {
    std::vector<float> batch;
    for (int i = 0; i < rows; ++i) {
      for (int j = 0; j < kSize; ++j) batch.push_back(offset[j] + scale[j] * normal(rng));
    }
    stats.Update(batch.data(), rows);
    all.insert(all.end(), batch.begin(), batch.end());

    std::vector<double> mean, var;
    DirectStats(all, kSize, &mean, &var);
    const double n = static_cast<double>(all.size() / kSize);
    EXPECT_EQ(stats.count(), n);
    for (int j = 0; j < kSize; ++j) {
      EXPECT_NEAR(stats.mean()[j], mean[j], 1e-10 * std::abs(mean[j]) + 1e-300)
          << "after " << n << " rows, column " << j;
      EXPECT_NEAR(stats.var()[j], var[j], 1e-10 * var[j]) << "after " << n << " rows, column " << j;
    }
    if (rows == 1) {
      // One row: the prior variance of 1 carries no weight; the spread of one sample is 0.
      for (int j = 0; j < kSize; ++j) EXPECT_EQ(stats.var()[j], 0.0);
    }
  }
  EXPECT_EQ(stats.count(), 108);
}

TEST(RunningStats, ResumesFromSavedStatistics) {
  // Saved: 4 samples of one column with mean 2 and variance 1 (e.g. 1, 1, 3, 3); merged with
  // [5, 7]: all six are 1, 1, 3, 3, 5, 7, mean 20 / 6, variance (sum x^2 = 94) 94/6 - (20/6)^2.
  RunningStats stats({2.0}, {1.0}, 4);
  const float batch[] = {5.0f, 7.0f};
  stats.Update(batch, 2);
  EXPECT_EQ(stats.count(), 6);
  EXPECT_NEAR(stats.mean()[0], 20.0 / 6, 1e-14);
  EXPECT_NEAR(stats.var()[0], 94.0 / 6 - (20.0 / 6) * (20.0 / 6), 1e-13);
}

TEST(RunningStats, NormalizeMatchesHandComputationAndClips) {
  RunningStats stats({1.0, -2.0}, {4.0, 0.25}, 10);
  const float in[] = {3.0f,   -2.0f,  //
                      -1.0f,  -1.5f,  //
                      101.0f, -12.0f};
  float out[6];
  stats.Normalize(in, 3, out);
  // (x - mean) / sqrt(var + 1e-8)
  EXPECT_FLOAT_EQ(out[0], static_cast<float>(2.0 / std::sqrt(4.0 + 1e-8)));  // ~1
  EXPECT_FLOAT_EQ(out[1], 0.0f);
  EXPECT_FLOAT_EQ(out[2], static_cast<float>(-2.0 / std::sqrt(4.0 + 1e-8)));  // ~-1
  EXPECT_FLOAT_EQ(out[3], static_cast<float>(0.5 / std::sqrt(0.25 + 1e-8)));  // ~1
  // 100 / 2 = 50 and -10 / 0.5 = -20, clipped to the default +-10.
  EXPECT_EQ(out[4], 10.0f);
  EXPECT_EQ(out[5], -10.0f);

  // A tighter clip and a large epsilon: (x - mean) / sqrt(var + 0.75).
  stats.Normalize(in, 3, out, /*clip=*/1.5, /*epsilon=*/0.75);
  EXPECT_FLOAT_EQ(out[0], static_cast<float>(2.0 / std::sqrt(4.75)));  // 0.917663
  EXPECT_FLOAT_EQ(out[1], 0.0f);
  EXPECT_FLOAT_EQ(out[2], static_cast<float>(-2.0 / std::sqrt(4.75)));
  EXPECT_FLOAT_EQ(out[3], 0.5f);  // 0.5 / sqrt(1)
  EXPECT_EQ(out[4], 1.5f);
  EXPECT_EQ(out[5], -1.5f);
}

TEST(RunningStats, ZeroVarianceColumnIsScaledByEpsilonNotInfinity) {
  RunningStats stats({0.0}, {0.0}, 3);
  const float in[] = {1e-5f, 0.0f};
  float out[2];
  stats.Normalize(in, 2, out, /*clip=*/5.0, /*epsilon=*/1e-8);
  EXPECT_FLOAT_EQ(out[0], 0.1f);  // 1e-5 / 1e-4
  EXPECT_EQ(out[1], 0.0f);
}

TEST(RunningStats, BatchMomentsMatchHandComputation) {
  // Columns {1, 3, 5} and {10, 20, 60}: means 3 and 30; squared deviations 4 + 0 + 4 and
  // 400 + 100 + 900.
  const float batch[] = {1, 10, 3, 20, 5, 60};
  RunningStats::Moments m = RunningStats::BatchMoments(batch, 3, 2);
  EXPECT_EQ(m.mean, (std::vector<double>{3.0, 30.0}));
  EXPECT_EQ(m.m2, (std::vector<double>{8.0, 1400.0}));
  // No rows: zeros, never 0 / 0.
  m = RunningStats::BatchMoments(nullptr, 0, 2);
  EXPECT_EQ(m.mean, (std::vector<double>{0.0, 0.0}));
  EXPECT_EQ(m.m2, (std::vector<double>{0.0, 0.0}));
}

TEST(RunningStats, EmptyBatchChangesNothing) {
  RunningStats stats({1.5, -0.5}, {2.0, 0.1}, 12);
  const float unused[] = {100.0f, 100.0f};
  stats.Update(unused, 0);
  stats.Update(nullptr, 0);
  EXPECT_EQ(stats.count(), 12);
  EXPECT_EQ(stats.mean(), (std::vector<double>{1.5, -0.5}));
  EXPECT_EQ(stats.var(), (std::vector<double>{2.0, 0.1}));

  RunningStats fresh(2);
  fresh.Update(nullptr, 0);
  EXPECT_EQ(fresh.count(), 0);
  EXPECT_EQ(fresh.mean(), (std::vector<double>{0.0, 0.0}));
  EXPECT_EQ(fresh.var(), (std::vector<double>{1.0, 1.0}));
}

}  // namespace
}  // namespace ragdoll
