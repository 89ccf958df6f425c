// Recovery trials on a trained policy: the character is dropped into random fallen states
// (sim::SettledFall: on its front, back or a side) and the deterministic policy runs; a trial
// recovers once the character stands (sim::PostureOf: trunk upright, root above 0.8 of the
// clip's first frame's height) and keeps standing for `hold` seconds. No contact ends a trial.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/wire.h"
#include "sim/env_config.h"

namespace ragdoll::eval {

struct RecoveryConfig {
  int trials = 100;
  double seconds = 10;  // watched per trial
  double hold = 0.5;    // s standing that count as up
};

struct RecoveryResult {
  RecoveryConfig config;
  std::vector<double> times;           // per trial, s until it stood; negative: it did not
  std::vector<std::string> postures;   // per trial, how it lay
  double within_5 = 0, within_10 = 0;  // shares standing within 5 s and 10 s
  double median_seconds = -1;          // over every trial (one that never stood counts as never)
  std::string ToTable() const;
  std::string ToJson() const;  // an object, the evaluation JSON's "recovery"
};

// Throws ConfigError for no trials or non-positive durations.
RecoveryResult EvaluateRecovery(const sim::EnvConfig& env, const v1::PolicySnapshot& snapshot,
                                const RecoveryConfig& config, uint64_t seed);

}  // namespace ragdoll::eval
