// A trained policy written for game engines: the ONNX model (exports/onnx_export.h) and beside it
// the JSON sidecar (exports/sidecar.h). They are made together because each names the other: the
// model's metadata names the run, clip, character and sidecar, and the sidecar holds the model's
// checksum.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "run/trained_policy.h"

namespace ragdoll::exports {

struct PolicyExportRequest {
  std::string onnx;     // the model file to write, e.g. policy.onnx
  std::string sidecar;  // the sidecar to write; empty: the model's path with .json
  bool value = false;   // also output the critic's value [batch, 1]
};

// What was written, for the command's report.
struct PolicyExport {
  std::string sidecar;  // the sidecar's path
  size_t model_bytes = 0;
  int64_t opset = 0;  // the model's ONNX opset
  int observation_size = 0, action_size = 0;
};

// Builds an environment from the policy's own configuration (the sidecar describes its layout),
// then the model and the sidecar, and writes both through WritePolicyFiles, so that a failure
// leaves neither written. Throws ConfigError for a file of the run that cannot be read, and
// std::runtime_error or std::invalid_argument for a model that cannot be built, checked or
// written.
PolicyExport ExportPolicy(const run::TrainedPolicy& policy, const PolicyExportRequest& request);

}  // namespace ragdoll::exports
