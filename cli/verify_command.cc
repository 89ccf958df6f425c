#include "cli/verify_command.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "common/run_config.h"
#include "learner/checkpoint_file.h"
#include "learner/checkpoint_store.h"
#include "learner/learner.h"
#include "run/experiment.h"
#include "sim/imitation_env.h"

namespace ragdoll::cli {
namespace {
namespace fs = std::filesystem;

// The checkpoint files of a run folder, or the file itself.
std::vector<fs::path> CheckpointFiles(const fs::path& target) {
  if (fs::is_regular_file(target)) return {target};
  return learner::Checkpoints(target / "checkpoints");
}

// "" when every weight and statistic is finite, else what is not.
std::string NonFinite(learner::Learner& l) {
  for (auto* module : {static_cast<torch::nn::Module*>(l.policy().get()),
                       static_cast<torch::nn::Module*>(l.critic().get())}) {
    for (const auto& p : module->named_parameters()) {
      if (!torch::isfinite(p.value()).all().item<bool>()) return "weights " + p.key();
    }
  }
  for (double x : l.stats().mean()) {
    if (!std::isfinite(x)) return "observation mean";
  }
  for (double x : l.stats().var()) {
    if (!std::isfinite(x)) return "observation variance";
  }
  return "";
}

}  // namespace

std::function<int()> AddVerifyCommand(CLI::App& app) {
  auto targets = std::make_shared<std::vector<std::string>>();
  auto* cmd = app.add_subcommand(
      "verify", "check that checkpoints are whole, load, and hold only finite numbers");
  cmd->add_option("run_or_checkpoint", *targets, "runs/<id> or checkpoint files")->required();
  return [cmd, targets]() -> int {
    if (!*cmd) return -1;
    int bad = 0, checked = 0;
    for (const auto& target : *targets) {
      const auto files = CheckpointFiles(target);
      if (files.empty()) {
        std::printf("BAD  %s: no checkpoint\n", target.c_str());
        ++bad;
        continue;
      }
      for (const auto& file : files) {
        ++checked;
        try {
          bool verified = false;
          learner::ReadCheckpointFile(file.string(), &verified);
          // Checkpoints live in <run>/checkpoints/; the run's effective config beside them.
          run::Experiment e =
              run::ReadExperiment(RunConfigPath(file.parent_path().parent_path().string()));
          const sim::EnvSpec spec = sim::MakeEnvSpec(e.environment);
          learner::Learner l(e.trainer, spec.observation_size, spec.action_size);
          l.Load(file.string());
          const std::string non_finite = NonFinite(l);
          if (!non_finite.empty()) {
            std::printf("BAD  %s: non-finite %s\n", file.c_str(), non_finite.c_str());
            ++bad;
            continue;
          }
          std::printf("ok   %s: policy v%lld, %lld samples, %s\n", file.c_str(),
                      static_cast<long long>(l.version()), static_cast<long long>(l.samples()),
                      verified ? "checksum verified" : "written before checksums (unverified)");
        } catch (const std::exception& error) {
          std::printf("BAD  %s\n", error.what());
          ++bad;
        }
      }
    }
    std::fprintf(stderr, "ragdoll verify: %d of %d checkpoints bad\n", bad, checked);
    return bad == 0 ? 0 : 1;
  };
}

}  // namespace ragdoll::cli
