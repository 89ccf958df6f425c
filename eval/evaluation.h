// Deterministic evaluation of a policy snapshot: N episodes from random phases with the mean
// action, reporting normalised return, episode length, fall rate and every reward term.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/wire.h"
#include "sim/env_config.h"
#include "sim/imitation_env.h"

namespace ragdoll::actor {
class RolloutWorker;
}  // namespace ragdoll::actor

namespace ragdoll::eval {

struct EvaluationResult {
  int episodes = 0;
  double mean_return = 0;
  double normalized_return = 0;
  double episode_length = 0;  // steps
  double fall_rate = 0;
  // The environment's episode figures (its spec's names, units and count of reward terms) and
  // their means: the reward terms go under "reward_terms", the task's own figures under the
  // task's name, those in radians as name_deg in degrees.
  sim::EnvSpec spec;
  std::vector<double> figures;
  // With push trials (push_evaluation.h), they go under "perturbation".
  std::string ToJson(const struct RobustnessResult* pushes = nullptr) const;
};

EvaluationResult Evaluate(const sim::EnvConfig& env, const v1::PolicySnapshot& snapshot,
                          int episodes, uint64_t seed);
// The same with a worker that has its policy (episodes of its environment 0).
EvaluationResult Evaluate(actor::RolloutWorker& worker, int episodes);
// The same episodes without a policy, every PD target at the reference pose: the "tracking
// alone" baseline that shows what learning added.
EvaluationResult EvaluateReferenceTracking(const sim::EnvConfig& env, int episodes, uint64_t seed);

}  // namespace ragdoll::eval
