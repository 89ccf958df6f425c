// Measures the imitation environment against the raw physics it is built on, and the
// no-learning baseline of each clip (PD targets set to the reference pose).
//
//   ragdoll-bench-env [--steps N] [--repeats R] [CONFIG...]
//
// Physics: the character's mj_step rate on one core, replaying exactly the controls and resets
// of an environment run, so both do the same physics work. Environment: control steps/s of K
// environments stepped in lockstep in one process (K = 1, 8, 32), and their ratio to the
// raw-physics bound (raw steps/s / substeps). Figures are medians over R repeats.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>
#include <vector>

#include "bench/measure.h"
#include "character/character.h"
#include "common/allocator.h"
#include "common/blas.h"
#include "common/config_section.h"
#include "common/median.h"
#include "sim/env_config.h"
#include "sim/imitation_env.h"
#include "sim/motion_set.h"

namespace {

using namespace ragdoll;
using namespace ragdoll::sim;
using ragdoll::character::Character;
using Clock = std::chrono::steady_clock;

struct Experiment {
  std::string config_path;
  EnvConfig config;
  std::shared_ptr<const Character> character;
  std::shared_ptr<const MotionSet> motions;
};

Experiment LoadExperiment(const std::string& path) {
  Experiment e;
  e.config_path = path;
  ConfigSection root = ConfigSection::FromFile(path);
  e.config = ReadEnvConfig(root.Section("environment"), character::DefaultCharacterPath());
  e.character = Character::Load(e.config.character, e.config.physics_dt());
  e.motions = LoadMotionSet(e.config, *e.character);
  return e;
}

// Control steps per second of K environments in lockstep, each replaying the recording.
double EnvRate(const Experiment& e, const bench::Recording& r, int k, uint64_t seed) {
  std::vector<std::unique_ptr<ImitationEnv>> envs;
  for (int i = 0; i < k; ++i) {
    envs.push_back(std::make_unique<ImitationEnv>(e.character, e.motions, e.config, seed));
  }
  const int na = envs[0]->spec().action_size;
  const int no = envs[0]->spec().observation_size;
  std::vector<float> obs(static_cast<size_t>(k) * no);
  const int steps = static_cast<int>(r.reset_before.size()) / k;
  auto start = Clock::now();
  for (int i = 0; i < k; ++i) envs[i]->Reset(obs.data() + i * no);
  for (int t = 0; t < steps; ++t) {
    for (int i = 0; i < k; ++i) {
      StepResult s =
          envs[i]->Step(r.actions.data() + static_cast<size_t>(t) * na, obs.data() + i * no);
      if (s.terminated || s.truncated) envs[i]->Reset(obs.data() + i * no);
    }
  }
  double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return static_cast<double>(steps) * k / seconds;
}

struct Baseline {
  double normalized_return = 0, length = 0, fall_rate = 0;
  RewardTerms terms;
};

// PD tracking of the reference pose, no learning: `episodes` episodes from random phases.
Baseline RunBaseline(const Experiment& e, int episodes, uint64_t seed) {
  ImitationEnv env(e.character, e.motions, e.config, seed);
  std::vector<float> obs(env.spec().observation_size), action(env.spec().action_size);
  Baseline b;
  for (int ep = 0; ep < episodes; ++ep) {
    env.Reset(obs.data());
    for (;;) {
      env.ReferenceAction(action.data());
      StepResult s = env.Step(action.data(), obs.data());
      if (s.terminated || s.truncated) break;
    }
    const EpisodeStats& st = env.episode();
    b.normalized_return += st.normalized_return / episodes;
    b.length += static_cast<double>(st.length) / episodes;
    b.fall_rate += (st.fell() ? 1.0 : 0.0) / episodes;
    b.terms.rotation += st.mean_terms.rotation / episodes;
    b.terms.velocity += st.mean_terms.velocity / episodes;
    b.terms.end_effector += st.mean_terms.end_effector / episodes;
    b.terms.com += st.mean_terms.com / episodes;
    b.terms.root += st.mean_terms.root / episodes;
  }
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  ragdoll::blas::ChooseKernels(argv);
  ragdoll::allocator::KeepLargeBlocks();
  CLI::App app("Environment throughput against raw MuJoCo, and no-learning baselines.");
  std::vector<std::string> configs;
  int steps = 1000, repeats = 11, episodes = 50;
  bool skip_speed = false;
  app.add_option("configs", configs, "experiment configs (their environment sections)")->required();
  app.add_option("--steps", steps, "control steps per speed measurement")->capture_default_str();
  app.add_option("--repeats", repeats, "repeats per speed figure (median)")->capture_default_str();
  app.add_option("--episodes", episodes, "episodes per baseline")->capture_default_str();
  app.add_flag("--baseline-only", skip_speed, "skip the speed measurements");
  CLI11_PARSE(app, argc, argv);
  try {
    bool first = true;
    for (const auto& path : configs) {
      Experiment e = LoadExperiment(path);
      if (!skip_speed && first) {
        first = false;
        std::printf("speed (%s, %g Hz control, %d substeps, median of %d):\n", path.c_str(),
                    e.config.control_frequency, e.config.substeps, repeats);
        const int ks[] = {1, 8, 32};
        // Raw and environment runs alternate within each repeat, and each repeat yields its own
        // ratio: on a noisy machine the median of paired ratios is steadier than a ratio of
        // medians.
        std::vector<double> raw;
        std::vector<std::vector<double>> env(3), ratio(3);
        for (int rep = 0; rep < repeats; ++rep) {
          bench::Recording r1 = bench::Record(e.config, e.character, e.motions, steps, 1);
          raw.push_back(bench::RawPhysicsRate(*e.character, e.config.substeps, r1));
          for (int i = 0; i < 3; ++i) {
            // Each of the K environments replays the same recording (same seed, same actions),
            // so all do the same physics as the raw loop.
            bench::Recording rk = r1;
            std::vector<float> actions;
            for (int t = 0; t < steps / ks[i]; ++t) {
              actions.insert(
                  actions.end(),
                  r1.actions.begin() + static_cast<long>(t) * e.character->model()->nu,
                  r1.actions.begin() + static_cast<long>(t + 1) * e.character->model()->nu);
            }
            rk.actions = actions;
            rk.reset_before.resize(static_cast<size_t>(steps / ks[i]) * ks[i]);
            env[i].push_back(EnvRate(e, rk, ks[i], 1));
            double raw_again = bench::RawPhysicsRate(*e.character, e.config.substeps, r1);
            double bound_here = 0.5 * (raw.back() + raw_again) / e.config.substeps;
            ratio[i].push_back(env[i].back() / bound_here);
          }
        }
        double raw_rate = Median(raw);
        double bound = raw_rate / e.config.substeps;
        std::printf(
            "  raw mj_step                  %9.0f physics steps/s  (bound %.0f control steps/s)\n",
            raw_rate, bound);
        for (int i = 0; i < 3; ++i) {
          double rate = Median(env[i]);
          std::printf(
              "  environment K=%-2d             %9.0f control steps/s  %.3f of bound (overhead "
              "%+.1f %%)\n",
              ks[i], rate, rate / bound, 100 * (bound / rate - 1));
        }
      }
      Baseline b = RunBaseline(e, episodes, 7);
      std::printf(
          "baseline %-28s normalised return %.3f  length %5.1f steps (%.2f s)  fall rate %.2f  "
          "terms rot %.3f vel %.3f ee %.3f com %.3f root %.3f\n",
          e.motions->entry(0).name.c_str(), b.normalized_return, b.length,
          b.length * e.config.control_dt(), b.fall_rate, b.terms.rotation, b.terms.velocity,
          b.terms.end_effector, b.terms.com, b.terms.root);
      std::fflush(stdout);
    }
  } catch (const std::exception& ex) {
    std::cerr << "ragdoll-bench-env: " << ex.what() << "\n";
    return 1;
  }
  return 0;
}
