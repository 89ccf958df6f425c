// Actor throughput with the policy in the loop against the environments alone, same process,
// same K environments: the cost of observation normalisation, the batched libtorch forward and
// Gaussian sampling on top of the simulation.
//   ragdoll-bench-actor CONFIG [--environments K] [--repeats R] [--steps T]
#include <torch/torch.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "actor/rollout.h"
#include "actor/sim/motion_set.h"
#include "cli/experiment.h"
#include "common/config_section.h"
#include "common/median.h"

namespace {

using Clock = std::chrono::steady_clock;

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

    // The environments alone: a second set of K environments with the same seeds replays,
    // step for step, the actions the policy loop sampled. Both loops therefore simulate the
    // identical trajectories (rollouts are bit-identical for a seed), fall and reset at the same
    // steps; the difference is only the policy: normalisation, the batched forward, sampling and
    // building the segments. Packing the segments for the wire is timed separately.
    auto character = sim::Character::Load(e.environment.character, e.environment.physics_dt());
    auto motions = sim::LoadMotionSet(e.environment, *character);
    std::vector<std::unique_ptr<sim::ImitationEnv>> envs;
    for (int k = 0; k < K; ++k) {
      envs.push_back(std::make_unique<sim::ImitationEnv>(character, motions, e.environment, 1 + k));
    }
    const int O = worker.spec().observation_size, A = worker.spec().action_size;
    std::vector<float> obs(static_cast<size_t>(K) * O);
    for (int k = 0; k < K; ++k) envs[k]->Reset(obs.data() + k * O);

    std::vector<double> with_policy, env_only, ratio, packed_ratio;
    int64_t resets = 0;
    size_t bytes = 0;
    for (int r = 0; r < repeats; ++r) {
      auto t0 = Clock::now();
      std::vector<v1::TrajectorySegment> segments = worker.Collect();
      const double policy_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
      auto tp = Clock::now();
      for (const auto& s : segments) {
        bytes += wire::Pack(v1::KIND_TRAJECTORY, "bench", "bench", s, s.policy_version()).size();
      }
      const double pack_seconds = std::chrono::duration<double>(Clock::now() - tp).count();

      std::vector<std::vector<float>> replay(K);
      for (int k = 0; k < K; ++k) replay[k] = wire::FloatValues(segments[k].actions());
      std::vector<float> replay_rewards(static_cast<size_t>(K) * steps);
      auto t1 = Clock::now();
      for (int t = 0; t < steps; ++t) {
        for (int k = 0; k < K; ++k) {
          sim::StepResult s = envs[k]->Step(replay[k].data() + t * A, obs.data() + k * O);
          replay_rewards[k * steps + t] = static_cast<float>(s.reward);
          if (s.terminated || s.truncated) {
            envs[k]->Reset(obs.data() + k * O);
            ++resets;
          }
        }
      }
      const double env_seconds = std::chrono::duration<double>(Clock::now() - t1).count();
      // The replay must have followed the policy loop's trajectories exactly.
      for (int k = 0; k < K; ++k) {
        std::vector<float> want = wire::FloatValues(segments[k].rewards());
        if (!std::equal(want.begin(), want.end(), replay_rewards.begin() + k * steps)) {
          throw std::runtime_error("replayed environment " + std::to_string(k) +
                                   " diverged from the policy loop");
        }
      }
      const double n = static_cast<double>(K) * steps;
      with_policy.push_back(n / policy_seconds);
      env_only.push_back(n / env_seconds);
      ratio.push_back(env_seconds / policy_seconds);
      packed_ratio.push_back(env_seconds / (policy_seconds + pack_seconds));
    }
    std::printf("actor (%s, K=%d, network %d x %zu, 1 thread, median of %d):\n", config.c_str(), K,
                e.trainer.network.hidden_units.front(), e.trainer.network.hidden_units.size(),
                repeats);
    std::printf("  environments alone (same actions)  %8.0f samples/s  (%lld resets)\n",
                Median(env_only), static_cast<long long>(resets));
    std::printf("  with policy in the loop            %8.0f samples/s  ratio %.3f\n",
                Median(with_policy), Median(ratio));
    std::printf(
        "  ... and packing the segments       %8s            ratio %.3f  (%.0f bytes/sample)\n", "",
        Median(packed_ratio),
        static_cast<double>(bytes) / (static_cast<double>(K) * steps * repeats));
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "ragdoll-bench-actor: %s\n", ex.what());
    return 1;
  }
  return 0;
}
