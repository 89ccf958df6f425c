#include "exports/policy_export.h"

#include <filesystem>
#include <map>

#include "actor/rollout.h"
#include "exports/onnx_export.h"
#include "exports/sidecar.h"

namespace ragdoll::exports {
namespace {
namespace fs = std::filesystem;

std::string SidecarPath(const PolicyExportRequest& request) {
  return request.sidecar.empty() ? fs::path(request.onnx).replace_extension(".json").string()
                                 : request.sidecar;
}

// The model's metadata_props: where it came from and how it is driven, so that a model file found
// without its sidecar still says which run it is and which sidecar to look for.
std::map<std::string, std::string> ModelMetadata(const run::TrainedPolicy& p,
                                                 const sim::ImitationEnv& env,
                                                 const std::string& sidecar) {
  const sim::EnvConfig& c = p.experiment.environment;
  return {
      {"ragdoll_version", RAGDOLL_VERSION},
      {"policy_version", std::to_string(p.version)},
      {"policy_samples", std::to_string(p.samples)},
      {"checkpoint", p.checkpoint},
      {"clip", env.clip().name()},
      {"character", env.character().path()},
      {"action_mode", c.action_mode == sim::ActionMode::kOffset ? "offset" : "absolute"},
      {"control_frequency", std::to_string(c.control_frequency)},
      {"sidecar", fs::path(sidecar).filename().string()},
  };
}

}  // namespace

PolicyExport ExportPolicy(const run::TrainedPolicy& policy, const PolicyExportRequest& request) {
  actor::RolloutWorker probe(policy.experiment.environment, 1, 1, 0, "probe");
  const sim::ImitationEnv& env = probe.environment(0);
  const std::string sidecar = SidecarPath(request);
  ValueHead value{ValueNetwork(policy.critic), policy.value_scale, policy.value_offset};
  const onnx::ModelProto model = BuildPolicyModel(policy.snapshot, request.value ? &value : nullptr,
                                                  ModelMetadata(policy, env, sidecar));
  const SidecarModel described{request.onnx, model.SerializeAsString(), request.value};
  const std::string text = PolicySidecar(policy, env, described).dump(2) + "\n";
  WritePolicyFiles(described.bytes, request.onnx, text, sidecar);
  return {sidecar, described.bytes.size(), kOnnxOpset, probe.spec().observation_size,
          probe.spec().action_size};
}

}  // namespace ragdoll::exports
