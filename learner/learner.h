// The learner's training state and the PPO update: buffers validated trajectory segments, runs
// PPO when a buffer is full, owns the observation statistics, and saves and restores
// checkpoints. No sockets here (learner/learner_process.h owns them).
#pragma once

#include <torch/torch.h>

#include <memory>
#include <string>
#include <vector>

#include "common/policy.h"
#include "common/running_stats.h"
#include "common/wire.h"
#include "learner/trainer_config.h"

namespace ragdoll::learner {

// Means over the minibatches of one update.
struct UpdateStats {
  double policy_loss = 0;
  double value_loss = 0;
  double entropy = 0;
  double approx_kl = 0;  // from the actors' behaviour policies (includes their lag)
  double update_kl = 0;  // of the last minibatch, from the policy the update started from
  double clip_fraction = 0;
  double explained_variance = 0;
  double learning_rate = 0;
  double seconds = 0;
  int64_t samples = 0;        // samples in this update
  int64_t skipped_steps = 0;  // gradient steps skipped for a non-finite gradient
};

// Episode statistics reported by actors since the last update.
struct EpisodeStatsSum {
  int64_t episodes = 0;
  double episode_return = 0, normalized_return = 0, length = 0, falls = 0;
  double rotation = 0, velocity = 0, end_effector = 0, com = 0, root = 0;
  void Add(const v1::EpisodeSummary& e);
  double Mean(double sum) const { return episodes ? sum / episodes : 0.0; }
};

class Learner {
 public:
  Learner(const TrainerConfig& config, int observation_size, int action_size);

  enum class Accept { kAccepted, kStale, kWrongLength };
  // Adds a segment that passed wire::CheckSegment for this learner's sizes.
  Accept Add(const v1::TrajectorySegment& segment);
  bool Ready() const { return buffered_samples_ >= config_.buffer_size; }
  // Runs PPO on the buffer, empties it, bumps the policy version.
  UpdateStats Update();

  v1::PolicySnapshot Snapshot();
  // Writes the whole training state atomically (temporary file, then rename).
  void Save(const std::string& path, const std::string& config_text);
  // Restores the state written by Save; throws ConfigError naming the file on any mismatch.
  // Returns the config text stored in the checkpoint.
  std::string Load(const std::string& path);
  // Copies only the network weights and observation statistics of a checkpoint (--init-from).
  void LoadWeights(const std::string& path);

  int64_t version() const { return version_; }
  int64_t samples() const { return samples_; }
  int64_t iterations() const { return iterations_; }
  int64_t stale_dropped() const { return stale_dropped_; }
  int64_t buffered_samples() const { return buffered_samples_; }
  const RunningStats& stats() const { return stats_; }
  const RunningStats& return_stats() const { return return_stats_; }
  const EpisodeStatsSum& episodes() const { return episodes_; }
  void ResetEpisodeStats() { episodes_ = EpisodeStatsSum(); }
  GaussianPolicy& policy() { return policy_; }
  ValueNetwork& critic() { return critic_; }
  torch::optim::Adam& optimizer() { return *optimizer_; }

 private:
  torch::Tensor Normalize(const torch::Tensor& observations) const;
  torch::Tensor ValueFromCritic(const torch::Tensor& output) const;
  torch::Tensor ValueToCritic(const torch::Tensor& value) const;

  TrainerConfig config_;
  int observation_size_, action_size_;
  GaussianPolicy policy_;
  ValueNetwork critic_;
  std::unique_ptr<torch::optim::Adam> optimizer_;
  RunningStats stats_;
  // Running mean and variance of the value targets (network_settings.normalize_value).
  RunningStats return_stats_{1};
  std::vector<v1::TrajectorySegment> buffer_;
  int64_t buffered_samples_ = 0;
  int64_t version_ = 0;
  int64_t samples_ = 0;
  int64_t iterations_ = 0;
  int64_t stale_dropped_ = 0;
  // The adaptive schedule's current rate (saved with checkpoints, so --resume continues it).
  double adaptive_learning_rate_;
  EpisodeStatsSum episodes_;
};

}  // namespace ragdoll::learner
