// Actor throughput with the policy in the loop against the environments alone, same process,
// same K environments: the cost of observation normalisation, the batched libtorch forward and
// Gaussian sampling on top of the simulation.
//   ragdoll-bench-actor CONFIG [--environments K] [--repeats R] [--steps T]
#include <torch/torch.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>

#include "actor/rollout.h"
#include "actor/sim/motion_io.h"
#include "common/cli/experiment.h"
#include "common/config_section.h"

namespace {

using Clock = std::chrono::steady_clock;

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  using namespace ragdoll;
  CLI::App app("Actor samples/s with the policy in the loop vs the environments alone.");
  std::string config;
  int environments = 0, repeats = 7, steps = 64;
  app.add_option("config", config, "experiment YAML")->required();
  app.add_option("--environments", environments, "K (default: the config's)");
  app.add_option("--repeats", repeats)->capture_default_str();
  app.add_option("--steps", steps, "steps per environment per measurement")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  try {
    cli::Experiment e = cli::ReadExperiment(config);
    const int K = environments > 0 ? environments : e.actor.environments;
    at::set_num_threads(1);
    actor::RolloutWorker worker(e.environment, K, steps, 1, "bench");
    GaussianPolicy policy(worker.spec().observation_size, worker.spec().action_size,
                          e.trainer.network);
    worker.SetPolicy(MakeSnapshot(policy, RunningStats(worker.spec().observation_size), 0, 0));

    // The environments alone: the same K environments, stepped with the policy's mean action of
    // the first step held (no forward, no sampling), so the simulation work is comparable.
    auto character = sim::Character::Load(e.environment.character, e.environment.physics_dt());
    auto clip = std::make_shared<const sim::MotionClip>(sim::LoadMotion(e.environment.motion));
    std::vector<std::unique_ptr<sim::ImitationEnv>> envs;
    for (int k = 0; k < K; ++k) {
      envs.push_back(std::make_unique<sim::ImitationEnv>(character, clip, e.environment, 1 + k));
    }
    const int O = worker.spec().observation_size, A = worker.spec().action_size;
    std::vector<float> obs(static_cast<size_t>(K) * O), action(A, 0.0f);
    for (int k = 0; k < K; ++k) envs[k]->Reset(obs.data() + k * O);

    std::vector<double> with_policy, env_only, ratio;
    for (int r = 0; r < repeats; ++r) {
      auto t0 = Clock::now();
      worker.Collect();
      double policy_rate =
          static_cast<double>(K) * steps / std::chrono::duration<double>(Clock::now() - t0).count();
      auto t1 = Clock::now();
      for (int t = 0; t < steps; ++t) {
        for (int k = 0; k < K; ++k) {
          sim::StepResult s = envs[k]->Step(action.data(), obs.data() + k * O);
          if (s.terminated || s.truncated) envs[k]->Reset(obs.data() + k * O);
        }
      }
      double env_rate =
          static_cast<double>(K) * steps / std::chrono::duration<double>(Clock::now() - t1).count();
      with_policy.push_back(policy_rate);
      env_only.push_back(env_rate);
      ratio.push_back(policy_rate / env_rate);
    }
    std::printf("actor (%s, K=%d, network %d x %zu, 1 thread, median of %d):\n", config.c_str(), K,
                e.trainer.network.hidden_units.front(), e.trainer.network.hidden_units.size(),
                repeats);
    std::printf("  environments alone        %8.0f samples/s\n", Median(env_only));
    std::printf("  with policy in the loop   %8.0f samples/s  ratio %.3f\n", Median(with_policy),
                Median(ratio));
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "ragdoll-bench-actor: %s\n", ex.what());
    return 1;
  }
  return 0;
}
