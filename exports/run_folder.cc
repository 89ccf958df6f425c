#include "exports/run_folder.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <vector>

#include "common/config_section.h"
#include "common/run_config.h"
#include "common/whole_file.h"
#include "learner/checkpoint_file.h"
#include "learner/learner.h"
#include "sim/imitation_env.h"

namespace ragdoll::exports {
namespace {
namespace fs = std::filesystem;

// Every scalar of `node` that is an absolute path to an existing file.
void CollectFilePaths(const YAML::Node& node, std::set<std::string>* out) {
  if (node.IsScalar()) {
    const std::string v = node.Scalar();
    std::error_code error;
    if (!v.empty() && v[0] == '/' && fs::is_regular_file(v, error)) out->insert(v);
  } else if (node.IsSequence()) {
    for (const auto& item : node) CollectFilePaths(item, out);
  } else if (node.IsMap()) {
    for (const auto& kv : node) CollectFilePaths(kv.second, out);
  }
}

// The files `config` (read from `origin`) names by absolute path.
std::set<std::string> FilePaths(const std::string& config, const std::string& origin) {
  std::set<std::string> paths;
  try {
    CollectFilePaths(YAML::Load(config), &paths);
  } catch (const YAML::Exception& e) {
    throw ConfigError(origin + ": " + e.what());
  }
  return paths;
}

// `config` with each of `paths` written relative to `out`.
std::string RelativeTo(std::string config, const std::set<std::string>& paths,
                       const fs::path& out) {
  // Longest first, so that no path is rewritten inside a longer one.
  std::vector<std::string> ordered(paths.begin(), paths.end());
  std::sort(ordered.begin(), ordered.end(),
            [](const std::string& a, const std::string& b) { return a.size() > b.size(); });
  for (const auto& path : ordered) {
    const std::string relative = fs::path(path).lexically_relative(out).string();
    for (size_t at = config.find(path); at != std::string::npos;
         at = config.find(path, at + relative.size())) {
      config.replace(at, path.size(), relative);
    }
  }
  return config;
}

// The policy's checkpoint saved again with `config` and without the optimizer's state.
std::string CheckpointWithoutOptimizer(const run::TrainedPolicy& p, const std::string& config) {
  const sim::EnvSpec spec = sim::MakeEnvSpec(p.experiment.environment);
  learner::Learner l(p.experiment.trainer, spec.observation_size, spec.action_size);
  l.Load(p.checkpoint);
  return l.SaveToBytes(config, /*with_optimizer=*/false);
}

}  // namespace

RunFolderExport ExportRunFolder(const run::TrainedPolicy& policy, const std::string& folder) {
  const fs::path out = fs::absolute(folder).lexically_normal();
  const fs::path run_dir = fs::path(policy.checkpoint).parent_path().parent_path();
  const std::string config_path = RunConfigPath(run_dir.string());
  const std::string original = ReadWholeFile(config_path);
  const std::set<std::string> paths = FilePaths(original, config_path);
  const std::string config = RelativeTo(original, paths, out);
  const std::string bytes = CheckpointWithoutOptimizer(policy, config);
  fs::create_directories(out / "checkpoints");
  const fs::path checkpoint = out / "checkpoints" / fs::path(policy.checkpoint).filename();
  learner::WriteCheckpointFile(checkpoint.string(), bytes);
  try {
    WriteRunConfig(out.string(), config, /*replace=*/true);
  } catch (const std::runtime_error& error) {
    throw ConfigError(error.what());
  }
  return {out.string(), checkpoint.lexically_relative(out).string(), paths.size(), bytes.size()};
}

}  // namespace ragdoll::exports
