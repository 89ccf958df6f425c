// The JSON sidecar written beside a policy's ONNX model (exports/onnx_export.h). The model holds
// only the network, so an engine integration needs the rest of the contract in a file it can read
// without the training code: the observation's layout, each action axis and how an action becomes
// a PD target, the control rate, the character and clip (with checksums, so a mismatch is seen),
// and the steering and recovery tasks when the run was trained with them
// (docs/engine-integration.md).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "run/trained_policy.h"
#include "sim/imitation_env.h"

namespace ragdoll::exports {

// The model the sidecar describes, as it is written.
struct SidecarModel {
  std::string onnx_path;  // where the model goes: the sidecar names its file, not its folder
  std::string bytes;      // the serialised model, for its size and checksum
  bool value = false;     // whether the model also outputs the critic's value
};

// The sidecar of `policy` exported as `model`. `env` is an environment built from the policy's
// own configuration: it knows the character, clip, motion set and observation layout the policy
// was trained on. Keys keep the order written (ordered_json) so that the file reads top-down,
// model first. Reads the character, clip and get-up clip files for their checksums; throws
// ConfigError when one cannot be read.
nlohmann::ordered_json PolicySidecar(const run::TrainedPolicy& policy, const sim::ImitationEnv& env,
                                     const SidecarModel& model);

}  // namespace ragdoll::exports
