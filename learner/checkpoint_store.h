// A run's checkpoints: files checkpoint-<samples>.pt in its checkpoints/ folder, the sample count
// zero-padded to 12 digits so that names sort oldest first. Each is written whole or not at all,
// with a checksum (learner/checkpoint_file.h).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace ragdoll::learner {

class Learner;

// The checkpoint files (checkpoint-*.pt) of a run's checkpoints/ folder, oldest first.
std::vector<std::filesystem::path> Checkpoints(const std::filesystem::path& folder);

// The newest checkpoint file of a run folder or a checkpoint path itself; "" when none.
std::string FindCheckpoint(const std::string& run_or_checkpoint);

// The newest checkpoint of a run folder that is whole (its checksum matches), or a checkpoint
// path itself when whole; "" when none. Each damaged one passed over is described in `skipped`
// (file and reason). A damaged file given by path throws ConfigError naming the damage.
std::string FindGoodCheckpoint(const std::string& run_or_checkpoint,
                               std::vector<std::string>* skipped = nullptr);

// The sample count a checkpoint's name carries: -1 for "" (no checkpoint), 0 for a name without.
int64_t CheckpointSamples(const std::string& path);

class CheckpointStore {
 public:
  // The store of run folder `run_dir`, keeping the newest `keep` checkpoints; creates its
  // checkpoints/ folder.
  CheckpointStore(const std::string& run_dir, int keep);

  const std::filesystem::path& folder() const { return folder_; }

  // Writes `learner`'s whole state as the checkpoint of its sample count and returns its path;
  // throws std::runtime_error when it cannot (a full disk), leaving the other files untouched.
  std::string Save(Learner& learner, const std::string& config_text);
  // Deletes the oldest checkpoints beyond `keep`.
  void DeleteBeyondKeep();

  // The newest whole checkpoint; "" when none. Each damaged one newer than it is set aside
  // (renamed *.damaged), so that the ones written from here on, whose sample counts are lower,
  // are not deleted before it; `set_aside` receives each one's description (file and reason).
  std::string NewestGood(std::vector<std::string>* set_aside);

 private:
  std::string run_dir_;
  std::filesystem::path folder_;
  int keep_;
};

}  // namespace ragdoll::learner
