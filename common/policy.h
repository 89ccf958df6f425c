// The policy network: a Gaussian MLP with a state-independent log standard deviation, and its
// conversion to and from the PolicySnapshot wire message. Shared by the learner (which trains
// it), the actors (which run it) and the evaluation tools.
#pragma once

#include <torch/torch.h>

#include <string>
#include <vector>

#include "common/network_config.h"
#include "common/running_stats.h"
#include "common/wire.h"

namespace ragdoll {

// An MLP with the given hidden layers and a linear output layer scaled down at initialisation
// (so that initial outputs are near zero, as in CleanRL's layer_init with std 0.01).
torch::nn::Sequential MakeMlp(int inputs, int outputs, const NetworkConfig& config,
                              double output_gain);

class GaussianPolicyImpl : public torch::nn::Module {
 public:
  GaussianPolicyImpl(int observation_size, int action_size, const NetworkConfig& config);
  // Mean action for normalised observations [B, obs].
  torch::Tensor forward(const torch::Tensor& observations);
  // The mean action [B, act], the log-probability of `actions` [B, act] (summed over
  // dimensions) and the entropy, both [B].
  struct Evaluation {
    torch::Tensor mean, log_prob, entropy;
  };
  Evaluation Evaluate(const torch::Tensor& observations, const torch::Tensor& actions);

  int observation_size() const { return observation_size_; }
  int action_size() const { return action_size_; }
  const NetworkConfig& config() const { return config_; }

  torch::nn::Sequential mean{nullptr};
  torch::Tensor log_std;

 private:
  int observation_size_, action_size_;
  NetworkConfig config_;
};
TORCH_MODULE(GaussianPolicy);

class ValueNetworkImpl : public torch::nn::Module {
 public:
  ValueNetworkImpl(int observation_size, const NetworkConfig& config);
  // V(s) for normalised observations [B, obs]: [B].
  torch::Tensor forward(const torch::Tensor& observations);
  torch::nn::Sequential net{nullptr};
};
TORCH_MODULE(ValueNetwork);

// The snapshot of a policy at `version` with the observation statistics it expects.
v1::PolicySnapshot MakeSnapshot(GaussianPolicy& policy, const RunningStats& stats, int64_t version,
                                int64_t samples);
// A policy built from a snapshot's architecture and weights, and its statistics. Throws
// std::invalid_argument when the snapshot's parameters do not fit its architecture.
GaussianPolicy PolicyFromSnapshot(const v1::PolicySnapshot& snapshot);
RunningStats StatsFromSnapshot(const v1::PolicySnapshot& snapshot);
// Copies a snapshot's weights into an existing policy of the same architecture; false (and the
// policy unchanged) when the architecture differs.
bool LoadSnapshotWeights(const v1::PolicySnapshot& snapshot, GaussianPolicy& policy);

}  // namespace ragdoll
