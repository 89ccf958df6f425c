// A whole experiment configuration: every section of a YAML file in configs/, read and
// validated at start-up by every role, so a typo stops all of them with the same message.
#pragma once

#include <yaml-cpp/yaml.h>

#include <string>

#include "actor/actor_process.h"
#include "broker/broker.h"
#include "common/metrics.h"
#include "learner/learner_process.h"
#include "learner/trainer_config.h"
#include "sim/env_config.h"

namespace ragdoll::run {

struct Experiment {
  std::string path;  // the file
  std::string name;  // its stem: the default run-id prefix and progress label
  std::string text;  // the effective configuration (YAML, paths made absolute)
  YAML::Node tree;   // the same, parsed: clone it to write a variant without reading a file again
  sim::EnvConfig environment;
  learner::TrainerConfig trainer;
  learner::ReplicaSettings learner;  // the `learner:` section
  broker::BrokerConfig broker;
  int actor_count = 0;       // actors.count; 0 = cores - 1, at least 1
  actor::ActorConfig actor;  // per-actor settings (id, run id and seed are set per process)
  MetricsConfig metrics;
  std::string keys_dir;  // security.keys: the CURVE keys folder; empty: plaintext
};

// Reads `path`; throws ConfigError naming file, line, key and a hint for any problem.
// `port_base` > 0 moves the five broker ports to port_base .. port_base + 4, the learner replicas'
// store to port_base + 5 and the metrics ports to port_base + 10 (learner), + 11 (broker),
// + 20 + i (actor i) and + 50 + i (learner replica i >= 1).
Experiment ReadExperiment(const std::string& path, int port_base = 0);

// actors.count resolved: cores - 1, at least 1, when not set.
int ResolveActorCount(int configured);

}  // namespace ragdoll::run
