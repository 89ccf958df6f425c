// Checkpoint files that cannot silently rot: one header line naming the format, the payload's
// length and its SHA-256 (libsodium), then the payload (a libtorch archive of the training
// state). A truncated or bit-flipped file is told apart from a good one before libtorch reads it.
//   ragdoll-checkpoint 1 bytes=1234567 sha256=<64 hex digits>\n<payload>
// Files written before checksums (a bare libtorch archive) still load, unverified.
#pragma once

#include <string>
#include <vector>

namespace ragdoll::learner {

// Writes `payload` with its header to `path` atomically: a temporary file in the same folder,
// flushed to disk, then renamed over `path`. On any failure (a full disk, a file size limit)
// throws std::runtime_error naming the file and the reason, removes the temporary file and leaves
// `path` and every other file as they were.
void WriteCheckpointFile(const std::string& path, const std::string& payload);

// The payload of a checkpoint file, verified. Throws std::runtime_error naming the file and what
// is wrong: unreadable, truncated (bytes found vs expected), checksum mismatch, or a header that
// is not one. `verified` (optional) says whether a checksum was checked (false: an old file).
std::string ReadCheckpointFile(const std::string& path, bool* verified = nullptr);

// The reason `path` is not a good checkpoint file, or "" when it is.
std::string CheckCheckpointFile(const std::string& path);

// SHA-256 of `data` as 64 lowercase hex digits.
std::string Sha256Hex(const std::string& data);

}  // namespace ragdoll::learner
