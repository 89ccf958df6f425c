// Actor throughput with the policy in the loop against the environments alone, same process,
// same K environments: the cost of observation normalisation, the batched libtorch forward and
// Gaussian sampling on top of the simulation.
//   ragdoll-bench-actor CONFIG [--environments K] [--repeats R] [--steps T]
#include <torch/torch.h>
#include <CLI/CLI.hpp>

#include <cstdio>
#include <string>

#include "bench/measure.h"
#include "common/allocator.h"
#include "common/blas.h"

int main(int argc, char** argv) {
  using namespace ragdoll;
  blas::ChooseKernels(argv);
  allocator::KeepLargeBlocks();
  CLI::App app("Actor samples/s with the policy in the loop vs the environments alone.");
  std::string config;
  int environments = 0, repeats = 7, steps = 64;
  app.add_option("config", config, "experiment YAML")->required();
  app.add_option("--environments", environments, "K (default: the config's)");
  app.add_option("--repeats", repeats)->capture_default_str();
  app.add_option("--steps", steps, "steps per environment per measurement")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  try {
    run::Experiment e = run::ReadExperiment(config);
    const int K = environments > 0 ? environments : e.actor.environments;
    at::set_num_threads(1);
    std::printf("%s\n", blas::Summary(true).c_str());
    const bench::ActorFigures f = bench::MeasureActor(e, K, steps, repeats);
    std::printf("actor (%s, K=%d, network %d x %zu, 1 thread, median of %d):\n", config.c_str(), K,
                e.trainer.network.hidden_units.front(), e.trainer.network.hidden_units.size(),
                repeats);
    std::printf("  environments alone (same actions)  %8.0f samples/s  (%lld resets)\n", f.env_only,
                static_cast<long long>(f.resets));
    std::printf("  with policy in the loop            %8.0f samples/s  ratio %.3f\n", f.with_policy,
                f.ratio);
    std::printf(
        "  ... and packing the segments       %8s            ratio %.3f  (%.0f bytes/sample)\n", "",
        f.packed_ratio, f.bytes_per_sample);
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "ragdoll-bench-actor: %s\n", ex.what());
    return 1;
  }
  return 0;
}
