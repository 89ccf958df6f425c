// A trained policy as an ONNX model for game engines: the deterministic policy (mean action) with
// the observation normalisation folded in, so the model takes the raw observation the
// environment builds and returns the action the actor passes to the environment; optionally the
// critic's value. Built with ONNX's own protobuf classes and checked with its checker.
#pragma once

#include <onnx/onnx_pb.h>

#include <cstdint>
#include <map>
#include <string>

#include "common/policy.h"
#include "common/wire.h"

namespace ragdoll::exports {

// Opset 13: inside Unity Sentis's 7-15 and every ONNX Runtime since 1.6 (Unreal's NNE runs
// ONNX Runtime), and every op the graph uses has its current definition there (Clip with tensor
// bounds since 11); docs/engine-integration.md. IR version 7 is the one that opset came with.
constexpr int64_t kOnnxOpset = 13;
constexpr int64_t kOnnxIrVersion = 7;

// Tensor names: "observation" [batch, obs] in; "action" [batch, act] and "value" [batch, 1] out.
extern const char* const kObservationInput;
extern const char* const kActionOutput;
extern const char* const kValueOutput;

// The critic and how its output becomes a value in return units:
// value = critic(normalised observation) * scale + offset (1 and 0 without value normalisation).
struct ValueHead {
  ValueNetwork critic{nullptr};
  double scale = 1, offset = 0;
};

// observation -> (observation - mean) * (1 / sqrt(var + 1e-8)), clipped to [-10, 10] (exactly as
// RunningStats::Normalize does for the actors) -> the policy's mean MLP -> action; with `value`,
// the same normalised observation -> the critic -> value. `metadata` goes into the model's
// metadata_props. Throws std::invalid_argument when the snapshot's weights or statistics do not fit
// its architecture or are not finite.
onnx::ModelProto BuildPolicyModel(const v1::PolicySnapshot& snapshot, const ValueHead* value,
                                  const std::map<std::string, std::string>& metadata);

// onnx::checker on the model, then strict shape inference (type checks, node errors thrown), as
// Python's onnx.checker.check_model(full_check=True). Throws std::runtime_error with the reason.
void CheckModel(const onnx::ModelProto& model);

// Writes a serialised model and its sidecar text after checking the model as read back from
// those bytes (CheckModel): both to temporary files beside their targets, then renamed into place,
// so a failure (a model the checker refuses, an unwritable folder, a full disk) leaves neither file
// written nor changed. Throws std::runtime_error naming the file.
void WritePolicyFiles(const std::string& model_bytes, const std::string& onnx_path,
                      const std::string& sidecar_text, const std::string& sidecar_path);

}  // namespace ragdoll::exports
