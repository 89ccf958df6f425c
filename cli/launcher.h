// `ragdoll train`: one broker, one learner and N actors as child processes of this binary on
// loopback; stops them all (the learner last but one, so it writes a final checkpoint) on
// Ctrl-C or when the learner finishes.
#pragma once

#include <atomic>
#include <string>

namespace ragdoll::cli {

struct TrainOptions {
  std::string config;
  std::string run_id;  // default: <config name>-<date>-<time>
  std::string runs_dir = "runs";
  bool resume = false;
  std::string init_from;
  int actors = 0;  // 0: from the config (actors.count), else cores - 1
  int port_base = 0;
  int replicas = 0;       // learner replicas; 0: from the config (learner.replicas)
  std::string keys;       // CURVE keys folder for every role; empty: the config's security.keys
  bool insecure = false;  // let the broker listen beyond loopback without keys
};

int RunTrain(const TrainOptions& options, const std::atomic<bool>& stop);

}  // namespace ragdoll::cli
