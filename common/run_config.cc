#include "common/run_config.h"

#include <filesystem>

#include "common/whole_file.h"

namespace ragdoll {
namespace fs = std::filesystem;

std::string RunConfigPath(const std::string& run_dir) {
  return (fs::path(run_dir) / kRunConfigFile).string();
}

void WriteRunConfig(const std::string& run_dir, const std::string& text, bool replace) {
  const std::string path = RunConfigPath(run_dir);
  if (!replace && fs::exists(path)) return;
  WriteWholeFile(path, text);
}

std::string ReadRunConfig(const std::string& run_dir) {
  const std::string path = RunConfigPath(run_dir);
  return fs::exists(path) ? ReadWholeFile(path) : std::string();
}

}  // namespace ragdoll
