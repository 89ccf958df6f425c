// K imitation environments stepped in lockstep with one batched policy forward per control step,
// producing one trajectory segment of T steps per environment.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "common/running_stats.h"
#include "common/wire.h"
#include "sim/env_config.h"
#include "sim/imitation_env.h"

namespace ragdoll {
class GaussianPolicyImpl;  // common/policy.h: kept out of this header, which then needs no libtorch
}

namespace ragdoll::actor {

// Sets how many threads libtorch runs the policy's forward pass on: for the whole process.
void SetPolicyThreads(int threads);

class RolloutWorker {
 public:
  // A task for each environment instead of the config's (MakeTask).
  using TaskFactory = std::function<std::unique_ptr<sim::Task>()>;
  // `seed` seeds the environments (seed, seed + 1, ...) and the action noise.
  RolloutWorker(const sim::EnvConfig& config, int environments, int time_horizon, uint64_t seed,
                std::string actor_id, const TaskFactory& make_task = nullptr);

  const sim::EnvSpec& spec() const { return envs_.front()->spec(); }
  int environments() const { return static_cast<int>(envs_.size()); }

  // Installs a snapshot's policy, action noise and observation statistics. Call between
  // segments only. Throws std::invalid_argument when its sizes do not match the environment.
  void SetPolicy(const v1::PolicySnapshot& snapshot);
  bool has_policy() const { return policy_version_ >= 0; }
  int64_t policy_version() const { return policy_version_; }

  // Steps every environment T times with the current policy; one segment per environment.
  std::vector<v1::TrajectorySegment> Collect();
  // Mean actions for the current observations (deterministic evaluation); [K, act].
  void Act(bool deterministic, std::vector<float>* actions, std::vector<float>* log_probs);

  // Runs environment 0 from a reset to the end of one episode (for evaluation).
  sim::EpisodeStats RunEpisode(bool deterministic);
  // For tools that watch or disturb one episode (rendering, pushes): environment k, one control
  // step of environment 0 with the policy, and a restart of environment 0 at a clip phase.
  sim::ImitationEnv& environment(int k) { return *envs_[k]; }
  sim::StepResult StepFirst(bool deterministic);
  void ResetFirst(double phase);
  // Steering: gives environment 0 a command (a motion-set entry) and refreshes its observation.
  void SetCommandFirst(int entry);
  // Puts environment 0 in a simulated state (nq and nv values) and refreshes its observation.
  void SetStateFirst(const double* qpos, const double* qvel);

  int64_t samples() const { return samples_; }

 private:
  std::vector<std::unique_ptr<sim::ImitationEnv>> envs_;
  int time_horizon_;
  std::string actor_id_;
  std::shared_ptr<GaussianPolicyImpl> policy_;
  RunningStats stats_;
  std::vector<float> log_std_;
  int64_t policy_version_ = -1;
  std::mt19937_64 noise_;
  std::vector<float> observations_;  // [K, obs]: each environment's current observation
  std::vector<float> normalized_;
  int64_t samples_ = 0;
};

}  // namespace ragdoll::actor
