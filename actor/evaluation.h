// Deterministic evaluation of a policy snapshot: N episodes from random phases with the mean
// action, reporting normalised return, episode length, fall rate and every reward term.
#pragma once

#include <cstdint>
#include <string>

#include "actor/sim/env_config.h"
#include "common/wire.h"

namespace ragdoll::actor {

struct EvaluationResult {
  int episodes = 0;
  double mean_return = 0;
  double normalized_return = 0;
  double episode_length = 0;  // steps
  double fall_rate = 0;
  double rotation = 0, velocity = 0, end_effector = 0, com = 0, root = 0;
  std::string ToJson() const;
};

EvaluationResult Evaluate(const sim::EnvConfig& env, const v1::PolicySnapshot& snapshot,
                          int episodes, uint64_t seed);

}  // namespace ragdoll::actor
