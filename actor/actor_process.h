// An actor process: a RolloutWorker wired to the broker. Waits for the first policy snapshot
// (with backoff), streams segments, swaps to newer snapshots between segments, sends heartbeats,
// reconnects by itself when the broker restarts, and returns when `stop` is set.
#pragma once

#include <atomic>
#include <cstdint>
#include <string>

#include "common/endpoints.h"
#include "sim/env_config.h"

namespace ragdoll::actor {

struct ActorConfig {
  int environments = 8;   // K environments stepped in lockstep
  int time_horizon = 64;  // T steps per segment (the trainer's time_horizon)
  int threads = 1;        // libtorch intra-op threads
  uint64_t seed = 1;
  std::string actor_id = "actor-0";
  std::string run_id;
  double heartbeat_interval = 1.0;  // seconds
  std::string metrics_bind = "127.0.0.1";
  int metrics_port = -1;  // Prometheus endpoint; < 0: none
};

// Returns the process exit code.
int RunActor(const sim::EnvConfig& env, const ActorConfig& config, const Endpoints& endpoints,
             const std::atomic<bool>& stop);

}  // namespace ragdoll::actor
