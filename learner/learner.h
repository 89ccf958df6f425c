// The learner's training state and the PPO update: buffers validated trajectory segments, runs
// PPO when a buffer is full, owns the observation statistics, and saves and restores
// checkpoints. No sockets here (learner/learner_process.h owns them).
#pragma once

#include <torch/torch.h>

#include <algorithm>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "common/policy.h"
#include "common/running_stats.h"
#include "common/wire.h"
#include "learner/replica_group.h"
#include "learner/trainer_config.h"

namespace ragdoll::learner {

class Collectives;

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
  double cpu_seconds = 0;     // this process's CPU time during the update, on every thread
  double gflop = 0;           // the gradient steps' forward and backward products (6 per weight)
  int64_t samples = 0;        // samples in this update
  int64_t skipped_steps = 0;  // gradient steps skipped for a non-finite gradient
};

// Episode statistics reported by actors since the last update.
struct EpisodeStatsSum {
  EpisodeStatsSum() = default;
  // Sums the episode figures of these names (the environment's spec), in this order; a figure
  // of another name is ignored.
  explicit EpisodeStatsSum(std::vector<std::string> names)
      : figure_names(std::move(names)), figures(figure_names.size(), 0.0) {}
  int64_t episodes = 0;
  double episode_return = 0, normalized_return = 0, length = 0, falls = 0;
  std::vector<std::string> figure_names;
  std::vector<double> figures;  // sums, as figure_names names them
  void Add(const v1::EpisodeSummary& e);
  double Mean(double sum) const { return episodes ? sum / episodes : 0.0; }
};

// The observation and action sizes a checkpoint was written for. Throws ConfigError for a file
// that is not a readable checkpoint.
std::pair<int, int> CheckpointSizes(const std::string& path);

class Learner {
 public:
  // With a `group` of replicas (which must outlive the learner), each replica buffers its share
  // of buffer_size and batch_size, and every update merges statistics and gradients across the
  // group, so all replicas take the same steps. Without one, the learner is alone.
  Learner(const TrainerConfig& config, int observation_size, int action_size,
          ReplicaGroup* group = nullptr);
  ~Learner();

  enum class Accept { kAccepted, kStale, kWrongLength };
  // Adds a segment that passed wire::CheckSegment for this learner's sizes (moved in when the
  // caller is done with it: a walk segment is 67 kB).
  Accept Add(v1::TrajectorySegment segment);
  bool Ready() const { return buffered_samples_ >= local_buffer_size_; }
  // Replicas only: a replica may go on taking segments while it waits for the others (below),
  // up to twice its share; past that it should leave them queued.
  bool Full() const { return buffered_samples_ >= 2 * local_buffer_size_; }
  // Replicas only: every replica calls this when Ready() or when it is asked to stop; true when
  // none of them is stopping (else none updates). Alone: !stopping. Until the last replica
  // joins, `meanwhile` runs over and over (each call returning within milliseconds): the
  // learner process takes fresh segments there once the others are late, so that a replica dealt
  // more than the others (one that joined first gets the queued backlog) trains on it now instead
  // of keeping it queued until it goes stale. The update then weighs each replica by the samples it
  // holds.
  bool AgreeToUpdate(bool stopping, const std::function<void()>& meanwhile = {});
  // Runs PPO on the buffer, empties it, bumps the policy version. With replicas, every replica
  // calls it together (after AgreeToUpdate), and the episode statistics become the group's.
  UpdateStats Update();
  // Replicas only: every replica takes rank 0's whole training state (after rank 0 loaded a
  // checkpoint or initial weights).
  void SyncFromRankZero();

  // Policy versions never go backward, even when training resumes from an older checkpoint:
  // the numbering continues above `version` (the newest one the broker or the actors hold).
  // Segments from a version ahead of this learner's do the same at the next update (up to
  // kMaxVersionAhead; further ahead they are dropped as impossible).
  void ContinueNumberingFrom(int64_t version);
  static constexpr int64_t kMaxVersionAhead = 100000;

  v1::PolicySnapshot Snapshot();
  // Writes the whole training state atomically, with its checksum (learner/checkpoint_file.h);
  // throws std::runtime_error when it cannot (a full disk), leaving other files untouched.
  void Save(const std::string& path, const std::string& config_text);
  // Restores the state written by Save; throws ConfigError naming the file on any mismatch,
  // truncation or checksum failure.
  // Returns the config text stored in the checkpoint.
  std::string Load(const std::string& path);
  // The same state as bytes (what Save writes to a file). Without the optimizer's state the
  // file is a third the size: the policy and critic to ship (`ragdoll export --run`); training
  // resumed from it starts the optimizer afresh.
  std::string SaveToBytes(const std::string& config_text, bool with_optimizer = true);
  std::string LoadFromBytes(const std::string& bytes, const std::string& source);
  // Copies only the network weights and observation statistics of a checkpoint (--init-from).
  // The checkpoint may have fewer observation entries than this learner (a task added on top,
  // its entries appended): the new entries start with zero weights and unit statistics. Throws
  // ConfigError for other sizes.
  void LoadWeights(const std::string& path);

  // Whether the last Load restored the optimizer's state (false: a checkpoint without it).
  bool optimizer_restored() const { return optimizer_restored_; }
  int64_t version() const { return version_; }
  // The newest policy version seen in a segment (-1: none yet).
  int64_t newest_seen_version() const { return newest_seen_; }
  int64_t samples() const { return samples_; }
  int64_t iterations() const { return iterations_; }
  int64_t stale_dropped() const { return stale_dropped_; }
  int64_t buffered_samples() const { return buffered_samples_; }
  // How many numbers the optimizer trains: what each gradient step's all-reduce carries (with
  // one more, the step's KL) when there are replicas.
  int64_t trained_parameters() const;
  // The samples of one of this replica's gradient steps when its buffer is full.
  int64_t minibatch_size() const { return std::min(local_batch_size_, local_buffer_size_); }
  const RunningStats& stats() const { return stats_; }
  const RunningStats& return_stats() const { return return_stats_; }
  const EpisodeStatsSum& episodes() const { return episodes_; }
  void ResetEpisodeStats() { episodes_ = EpisodeStatsSum(episodes_.figure_names); }
  // The episode figures to sum (the environment's EnvSpec::figure_names); every replica of a
  // group must be given the same.
  void SetFigureNames(std::vector<std::string> names) {
    episodes_ = EpisodeStatsSum(std::move(names));
  }
  GaussianPolicy& policy() { return policy_; }
  ValueNetwork& critic() { return critic_; }
  torch::optim::Adam& optimizer() { return *optimizer_; }

 private:
  struct Rollout;
  struct Batch;
  // The policy an update starts from: its means for every sample of the batch (`all_rows`),
  // or, when only the last step's distance from it is needed, for that minibatch's rows alone.
  struct OldPolicy {
    torch::Tensor means, log_std;
    bool all_rows = true;
  };

  int replicas() const;
  torch::Tensor Normalize(const torch::Tensor& observations) const;
  torch::Tensor CriticInChunks(const torch::Tensor& observations);
  torch::Tensor ValueFromCritic(const torch::Tensor& output) const;
  torch::Tensor ValueToCritic(const torch::Tensor& value) const;
  // The steps of Update, in order.
  Rollout GatherBuffer() const;
  Batch ComputeAdvantages(const Rollout& rollout);
  double ScheduledLearningRate() const;
  void SetLearningRate(double learning_rate);
  // One gradient step on the minibatch `mb_inds` of `b`; false when skipped for a non-finite
  // gradient. `measure_kl`: the step's distance from `old` is computed (else reported as 0).
  bool MinibatchStep(const Batch& b, const torch::Tensor& mb_inds,
                     const torch::Tensor& mb_advantages, const OldPolicy& old, bool measure_kl,
                     UpdateStats& stats);
  // The means over the `minibatches` steps taken, then over the group.
  void FinishStatistics(const Batch& b, int64_t minibatches, double weight, UpdateStats& stats);
  // The group's episode figures and samples (returned), from each replica's.
  int64_t SumEpisodesOverGroup(int64_t samples);
  int64_t NextVersion();
  void SaveArchive(torch::serialize::OutputArchive& archive, const std::string& config_text,
                   bool with_optimizer = true);
  std::string LoadArchive(torch::serialize::InputArchive& archive, const std::string& source);

  TrainerConfig config_;
  int observation_size_, action_size_;
  std::unique_ptr<Collectives> group_;  // of one, when the learner is alone
  int64_t local_buffer_size_;           // this replica's share of buffer_size
  int64_t local_batch_size_;            // and of batch_size
  GaussianPolicy policy_;
  ValueNetwork critic_;
  std::unique_ptr<torch::optim::Adam> optimizer_;
  RunningStats stats_;
  // Running mean and variance of the value targets (network_settings.normalize_value).
  RunningStats return_stats_{1};
  std::vector<v1::TrajectorySegment> buffer_;
  int64_t buffered_samples_ = 0;
  int64_t version_ = 0;
  int64_t newest_seen_ = -1;  // the newest policy version in a segment
  int64_t samples_ = 0;
  int64_t iterations_ = 0;
  int64_t stale_dropped_ = 0;
  bool optimizer_restored_ = false;
  // The adaptive schedule's current rate (saved with checkpoints, so --resume continues it).
  double adaptive_learning_rate_;
  EpisodeStatsSum episodes_;
};

}  // namespace ragdoll::learner
