#include "cli/export_command.h"

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "common/config_section.h"
#include "exports/policy_export.h"
#include "exports/run_folder.h"
#include "run/trained_policy.h"

namespace ragdoll::cli {
namespace {
namespace fs = std::filesystem;

struct ExportOptions {
  std::string target, onnx, sidecar, run;
  bool value = false;
};

void ReportRunFolder(const run::TrainedPolicy& p, const exports::RunFolderExport& r) {
  std::fprintf(stderr,
               "ragdoll export: %s (policy v%lld, %lld samples) -> %s: config.yaml (%zu file "
               "paths made relative to it) and %s (%zu bytes, no optimizer state)\n",
               p.checkpoint.c_str(), static_cast<long long>(p.version),
               static_cast<long long>(p.samples), r.folder.c_str(), r.relative_paths,
               r.checkpoint.c_str(), r.checkpoint_bytes);
}

void ReportPolicy(const run::TrainedPolicy& p, const ExportOptions& o,
                  const exports::PolicyExport& r) {
  std::fprintf(stderr,
               "ragdoll export: %s (policy v%lld, %lld samples) -> %s (%zu bytes, opset %lld: "
               "observation [batch, %d] -> action [batch, %d]%s) and %s\n",
               p.checkpoint.c_str(), static_cast<long long>(p.version),
               static_cast<long long>(p.samples), o.onnx.c_str(), r.model_bytes,
               static_cast<long long>(r.opset), r.observation_size, r.action_size,
               o.value ? ", value [batch, 1]" : "", r.sidecar.c_str());
}

int Export(const ExportOptions& o) {
  if (!fs::exists(o.target)) {
    throw ConfigError(o.target + ": no such run folder or checkpoint file");
  }
  if (o.onnx.empty() && o.run.empty()) throw ConfigError("give --onnx FILE, --run FOLDER or both");
  const run::TrainedPolicy p = run::LoadTrainedPolicy(o.target);
  if (!o.run.empty()) ReportRunFolder(p, exports::ExportRunFolder(p, o.run));
  if (o.onnx.empty()) return 0;
  ReportPolicy(p, o, exports::ExportPolicy(p, {o.onnx, o.sidecar, o.value}));
  return 0;
}

}  // namespace

std::function<int()> AddExportCommand(CLI::App& app) {
  auto o = std::make_shared<ExportOptions>();
  auto* cmd = app.add_subcommand(
      "export",
      "write the trained policy as an ONNX model for game engines, with a JSON sidecar, or as a "
      "run folder to ship");
  cmd->add_option("run_or_checkpoint", o->target, "runs/<id> or a checkpoint file")->required();
  cmd->add_option("--onnx", o->onnx, "the model file to write, e.g. policy.onnx");
  cmd->add_option("--run", o->run,
                  "also (or instead) write the run as a folder to ship: config.yaml with its "
                  "file paths relative to it, and the newest checkpoint without optimizer state "
                  "(eval, render and play take it like the run)");
  cmd->add_flag("--value", o->value, "also output the critic's value [batch, 1]");
  cmd->add_option("--sidecar", o->sidecar, "the JSON sidecar (default: the model's name, .json)");
  return [cmd, o]() -> int {
    if (!*cmd) return -1;
    try {
      return Export(*o);
    } catch (const std::exception& error) {
      std::fprintf(stderr, "ragdoll export: %s\n", error.what());
      return 1;
    }
  };
}

}  // namespace ragdoll::cli
