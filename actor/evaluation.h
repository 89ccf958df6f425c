// Deterministic evaluation of a policy snapshot: N episodes from random phases with the mean
// action, reporting normalised return, episode length, fall rate and every reward term.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "actor/sim/env_config.h"
#include "actor/sim/imitation_env.h"
#include "common/wire.h"

namespace ragdoll::actor {

class RolloutWorker;

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
  // With push trials, they go under "perturbation".
  std::string ToJson(const struct RobustnessResult* pushes = nullptr) const;
};

EvaluationResult Evaluate(const sim::EnvConfig& env, const v1::PolicySnapshot& snapshot,
                          int episodes, uint64_t seed);
// The same with a worker that has its policy (episodes of its environment 0).
EvaluationResult Evaluate(RolloutWorker& worker, int episodes);

// Push trials: from a random phase, the deterministic policy runs `settle` seconds, a body is
// pushed horizontally for `duration` seconds with a force of impulse / duration, and the trial
// fails if the character falls within `observe` seconds after. Every magnitude sees the same
// phases and directions.
struct PushConfig {
  std::string body = "root";
  std::vector<double> impulses = {0, 10, 20, 30, 40, 60, 80, 100};  // newton-seconds
  double duration = 0.1;
  int trials = 20;
  double settle = 1.0;
  double observe = 2.0;
  std::string direction = "random";  // or forward, backward, left, right (of the heading)
};

struct PushResult {
  double impulse = 0;  // N s
  double force = 0;    // N
  double fall_rate = 0;
  double normalized_return = 0;  // mean over the trials' whole episodes so far
};

struct RobustnessResult {
  PushConfig config;
  std::vector<PushResult> results;
  // The largest impulse survived in at least 90 % of the trials, this one and all smaller
  // ones; -1 if even the smallest is not.
  double survived_90 = -1;
  std::string ToTable() const;
  std::string ToJson() const;  // an object, for the evaluation JSON's "perturbation"
};

// Throws ConfigError for an unknown body or direction.
RobustnessResult EvaluatePushes(const sim::EnvConfig& env, const v1::PolicySnapshot& snapshot,
                                const PushConfig& push, uint64_t seed);

}  // namespace ragdoll::actor
