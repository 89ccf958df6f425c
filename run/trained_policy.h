// A trained policy as the tools (eval, render, export) use it: the newest checkpoint of a run
// folder (or a checkpoint file), the run's effective configuration, the policy snapshot and the
// critic.
#pragma once

#include <memory>
#include <string>

#include "common/wire.h"
#include "run/experiment.h"

namespace ragdoll {
class ValueNetworkImpl;  // common/policy.h: kept out of this header, which then needs no libtorch
}

namespace ragdoll::run {

struct TrainedPolicy {
  std::string checkpoint;
  Experiment experiment;  // the run's config.yaml
  v1::PolicySnapshot snapshot;
  int64_t version = 0;
  int64_t samples = 0;
  // The critic, and how its output becomes a value in return units (the learner's value
  // normalisation): value = critic(normalised observation) * value_scale + value_offset.
  std::shared_ptr<ValueNetworkImpl> critic;
  double value_scale = 1, value_offset = 0;
};

// Throws ConfigError when there is no checkpoint or it does not fit the run's config.
TrainedPolicy LoadTrainedPolicy(const std::string& run_or_checkpoint);

}  // namespace ragdoll::run
