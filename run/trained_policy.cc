#include "run/trained_policy.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <vector>

#include "common/config_section.h"
#include "common/run_config.h"
#include "learner/checkpoint_store.h"
#include "learner/learner.h"
#include "sim/imitation_env.h"

namespace ragdoll::run {

TrainedPolicy LoadTrainedPolicy(const std::string& run_or_checkpoint) {
  TrainedPolicy p;
  std::vector<std::string> damaged;
  p.checkpoint = learner::FindGoodCheckpoint(run_or_checkpoint, &damaged);
  for (const auto& reason : damaged) {
    std::fprintf(stderr, "ragdoll: %s; %s\n", reason.c_str(),
                 p.checkpoint.empty() ? "no older checkpoint is whole"
                                      : ("using the previous one, " + p.checkpoint).c_str());
  }
  if (p.checkpoint.empty()) {
    throw ConfigError(run_or_checkpoint +
                      (damaged.empty() ? ": no checkpoint found" : ": no whole checkpoint found"));
  }
  // Checkpoints live in <run>/checkpoints/; the run's effective config beside them.
  auto run = std::filesystem::path(p.checkpoint).parent_path().parent_path();
  p.experiment = ReadExperiment(RunConfigPath(run.string()));
  // Evaluation, play and export run the policy unpushed; their pushes are their own.
  p.experiment.environment.perturbations = {};
  // They start standing too; a fall still becomes a get-up.
  p.experiment.environment.recovery.start_fallen = 0;
  p.experiment.environment.recovery.start_getting_up = 0;
  // Early termination steers training; used, a get-up that goes wrong is tried again.
  p.experiment.environment.recovery.early_termination = false;
  const sim::EnvSpec spec = sim::MakeEnvSpec(p.experiment.environment);
  learner::Learner l(p.experiment.trainer, spec.observation_size, spec.action_size);
  l.Load(p.checkpoint);
  p.snapshot = l.Snapshot();
  p.version = l.version();
  p.samples = l.samples();
  p.critic = l.critic().ptr();
  p.critic->eval();
  if (p.experiment.trainer.normalize_value) {
    // As Learner::ValueFromCritic turns the critic's output into returns.
    p.value_scale = std::sqrt(l.return_stats().var()[0] + 1e-8);
    p.value_offset = l.return_stats().mean()[0];
  }
  return p;
}

}  // namespace ragdoll::run
