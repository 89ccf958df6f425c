// The learner process: a Learner wired to the broker, with progress lines and a metrics CSV
// (learner/training_log.h) and checkpoints (learner/checkpoint_store.h) in the run folder.
// Returns when max_steps is reached or `stop` is set, after a final checkpoint.
#pragma once

#include <atomic>
#include <string>
#include <vector>

#include "common/endpoints.h"
#include "learner/trainer_config.h"

namespace ragdoll {
class ConfigSection;
}

namespace ragdoll::learner {

// The `learner:` section: data-parallel replicas of the learner (c10d Gloo over TCP). Replicas
// find each other through the broker, which assigns their ranks; rank 0 serves the rendezvous
// store, publishes snapshots and writes checkpoints.
struct ReplicaSettings {
  int replicas = 1;
  int store_port = 5560;  // the TCPStore that rank 0 serves (--port-base: port_base + 5)
  // How the other replicas reach this one: "" = 127.0.0.1 when the broker is on loopback, else
  // this host's name (a container's name on a compose network).
  std::string address;
  double timeout = 300;  // seconds a collective waits for a replica that went silent
};

ReplicaSettings ReadReplicaSettings(const ConfigSection& section);

struct LearnerProcessConfig {
  std::string run_id;
  std::string run_dir;      // runs/<run-id>: checkpoints/, metrics.csv
  std::string label;        // shown in progress lines (the clip)
  std::string config_text;  // stored in every checkpoint
  int observation_size = 0;
  int action_size = 0;
  // The environment's episode figures (EnvSpec::figure_names), the first `reward_terms` of
  // them reward terms: columns of metrics.csv and gauges.
  std::vector<std::string> figure_names;
  int reward_terms = 0;
  bool resume = false;             // continue from the newest checkpoint in run_dir
  std::string init_from;           // or start from another run's (or checkpoint's) weights
  double republish_seconds = 2.0;  // resend the snapshot so a restarted broker has it
  std::string metrics_bind = "127.0.0.1";
  int metrics_port = -1;  // Prometheus endpoint; < 0: none
  ReplicaSettings replica;
  std::string replica_id = "learner";  // names this process to the broker (host and index)
};

// A group of replicas breaks when one of them stops or cannot be reached: the others throw
// std::runtime_error from RunLearner without writing a checkpoint, and the group resumes from the
// last one when restarted (`ragdoll train` restarts it; compose restarts the containers).
int RunLearner(const TrainerConfig& trainer, const LearnerProcessConfig& config,
               const Endpoints& endpoints, const std::atomic<bool>& stop);

}  // namespace ragdoll::learner
