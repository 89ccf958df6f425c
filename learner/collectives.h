// What a PPO update shares with the other replicas of its group, at the fixed points where it
// shares anything (Learner::Update). A lone learner is a group of one: its collectives send nothing
// and keep one learner's own arithmetic, so the update has one path either way.
#pragma once

#include <torch/torch.h>

#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "common/running_stats.h"
#include "learner/replica_group.h"

namespace ragdoll::learner {

// How a replica's samples split into the gradient steps of one epoch.
struct Minibatches {
  int64_t steps = 0;  // gradient steps per epoch, the same on every replica
  int64_t size = 0;   // this replica's samples per step
  double weight = 1;  // this replica's share of the group's minibatch
};

class Collectives {
 public:
  virtual ~Collectives() = default;

  virtual int rank() const = 0;
  virtual int size() const = 0;
  // In place over the group (contiguous float32, float64 or int64 tensors); every replica receives
  // the same bits. Sum runs `meanwhile` over and over until every replica has joined.
  virtual void Sum(torch::Tensor& tensor, const std::function<void()>& meanwhile = {}) = 0;
  virtual void Min(torch::Tensor& tensor) = 0;
  // Rank 0's `state()`, on every other replica; nullopt on rank 0 (which does not call it).
  virtual std::optional<std::string> FromRankZero(const std::function<std::string()>& state) = 0;

  // The running statistics take in `rows` ([rows, size] float32) of every replica.
  virtual void MergeStatistics(RunningStats& stats, const torch::Tensor& rows) = 0;
  // Splits this replica's `samples` into steps of about `batch_size` each.
  virtual Minibatches Split(int64_t samples, int64_t batch_size) = 0;
  // Before an epoch's steps: its order of the samples, and their advantages.
  virtual void StartEpoch(const torch::Tensor& advantages, const torch::Tensor& order) = 0;
  // A step's advantages (this replica's part of its minibatch), normalised over the group's
  // minibatch by its mean and unbiased standard deviation.
  virtual torch::Tensor NormalizedAdvantages(const torch::Tensor& advantages, int64_t step) = 0;
  // Leaves in every trained parameter's gradient the group's mean gradient of `loss`, and returns
  // the group's mean of `update_kl`.
  virtual double Backward(torch::optim::Optimizer& optimizer, const torch::Tensor& loss,
                          double update_kl) = 0;
};

// A lone learner's: nothing to send.
std::unique_ptr<Collectives> LoneCollectives();
// Over `group`, which must outlive them.
std::unique_ptr<Collectives> GroupCollectives(ReplicaGroup& group);

}  // namespace ragdoll::learner
