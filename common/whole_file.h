// Files read and written whole: a run's files (config.yaml, eval.json, a report page) are never
// seen half written, and a file that cannot be read names itself.
#pragma once

#include <string>

namespace ragdoll {

// The file's bytes, unchanged. Throws ConfigError ("PATH: cannot read") when it cannot be opened,
// so that a command reports which file is missing.
std::string ReadWholeFile(const std::string& path);

// Writes `bytes` to `path` through a temporary file beside it and a rename, so that a reader sees
// the old file or the new one, never half of one. Throws std::runtime_error naming the temporary
// file when it cannot be written.
void WriteWholeFile(const std::string& path, const std::string& bytes);

}  // namespace ragdoll
