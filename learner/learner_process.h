// The learner process: a Learner wired to the broker, with progress lines, a metrics CSV and
// checkpoints in the run folder. Returns when max_steps is reached or `stop` is set, after a
// final checkpoint.
#pragma once

#include <atomic>
#include <string>

#include "common/endpoints.h"
#include "learner/trainer_config.h"

namespace ragdoll::learner {

struct LearnerProcessConfig {
  std::string run_id;
  std::string run_dir;      // runs/<run-id>: checkpoints/, metrics.csv
  std::string label;        // shown in progress lines (the clip)
  std::string config_text;  // stored in every checkpoint
  int observation_size = 0;
  int action_size = 0;
  bool resume = false;             // continue from the newest checkpoint in run_dir
  std::string init_from;           // or start from another run's (or checkpoint's) weights
  double republish_seconds = 2.0;  // resend the snapshot so a restarted broker has it
  std::string metrics_bind = "0.0.0.0";
  int metrics_port = -1;  // Prometheus endpoint; < 0: none
};

int RunLearner(const TrainerConfig& trainer, const LearnerProcessConfig& config,
               const Endpoints& endpoints, const std::atomic<bool>& stop);

// The newest checkpoint file of a run folder or a checkpoint path itself; "" when none.
std::string FindCheckpoint(const std::string& run_or_checkpoint);

}  // namespace ragdoll::learner
