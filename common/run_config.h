// config.yaml in a run folder: the run's effective experiment configuration (YAML text, every
// path absolute), written when the run starts and read by every command that opens the run
// (eval, render, verify, export, report, --init-from). run/experiment.h parses it.
#pragma once

#include <string>

namespace ragdoll {

// The file's name in a run folder.
inline constexpr char kRunConfigFile[] = "config.yaml";

// RUN/config.yaml.
std::string RunConfigPath(const std::string& run_dir);

// Writes `text` as RUN/config.yaml, whole or not at all (a temporary file renamed). The run's
// first writer wins: an existing file is kept unless `replace`. Throws std::runtime_error naming
// the file when it cannot be written.
void WriteRunConfig(const std::string& run_dir, const std::string& text, bool replace = false);

// The text of RUN/config.yaml, or "" when the folder has none.
std::string ReadRunConfig(const std::string& run_dir);

}  // namespace ragdoll
