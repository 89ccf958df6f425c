// `export --run OUT`: a trained run as a folder to ship or check in. Its config.yaml names the
// files it uses (clips, character) relative to the folder, so the folder keeps working wherever
// it is moved with them; its one checkpoint holds the policy and critic without the optimizer's
// state, which only resuming the training needs and which would double its size.
#pragma once

#include <cstddef>
#include <string>

#include "run/trained_policy.h"

namespace ragdoll::exports {

// What was written, for the command's report.
struct RunFolderExport {
  std::string folder;         // absolute, normalised
  std::string checkpoint;     // relative to the folder
  size_t relative_paths = 0;  // file paths in config.yaml made relative to the folder
  size_t checkpoint_bytes = 0;
};

// Writes `policy`'s run (the config.yaml beside its checkpoints folder) and its checkpoint into
// `folder`, creating it. Throws ConfigError when the run's config.yaml cannot be read or parsed,
// and std::runtime_error (or a kind of it) naming the file that cannot be written.
RunFolderExport ExportRunFolder(const run::TrainedPolicy& policy, const std::string& folder);

}  // namespace ragdoll::exports
