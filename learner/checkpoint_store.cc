#include "learner/checkpoint_store.h"

#include <algorithm>
#include <cstdio>

#include "common/config_section.h"
#include "learner/checkpoint_file.h"
#include "learner/learner.h"

namespace ragdoll::learner {
namespace fs = std::filesystem;

std::vector<fs::path> Checkpoints(const fs::path& folder) {
  std::vector<fs::path> out;
  if (!fs::is_directory(folder)) return out;
  for (const auto& entry : fs::directory_iterator(folder)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("checkpoint-", 0) == 0 && entry.path().extension() == ".pt") {
      out.push_back(entry.path());
    }
  }
  std::sort(out.begin(), out.end());  // names carry zero-padded sample counts
  return out;
}

std::string FindCheckpoint(const std::string& run_or_checkpoint) {
  fs::path p(run_or_checkpoint);
  if (fs::is_regular_file(p)) return p.string();
  auto all = Checkpoints(p / "checkpoints");
  return all.empty() ? "" : all.back().string();
}

std::string FindGoodCheckpoint(const std::string& run_or_checkpoint,
                               std::vector<std::string>* skipped) {
  fs::path p(run_or_checkpoint);
  if (fs::is_regular_file(p)) {
    std::string damage = CheckCheckpointFile(p.string());
    if (!damage.empty()) throw ConfigError(damage);
    return p.string();
  }
  auto all = Checkpoints(p / "checkpoints");
  for (auto it = all.rbegin(); it != all.rend(); ++it) {
    std::string damage = CheckCheckpointFile(it->string());
    if (damage.empty()) return it->string();
    if (skipped) skipped->push_back(damage);
  }
  return "";
}

int64_t CheckpointSamples(const std::string& path) {
  if (path.empty()) return -1;
  const std::string stem = fs::path(path).stem().string();  // checkpoint-000000507904
  try {
    return std::stoll(stem.substr(stem.find('-') + 1));
  } catch (const std::exception&) {
    return 0;
  }
}

CheckpointStore::CheckpointStore(const std::string& run_dir, int keep)
    : run_dir_(run_dir), folder_(fs::path(run_dir) / "checkpoints"), keep_(keep) {
  fs::create_directories(folder_);
}

std::string CheckpointStore::Save(Learner& learner, const std::string& config_text) {
  char name[64];
  std::snprintf(name, sizeof(name), "checkpoint-%012lld.pt",
                static_cast<long long>(learner.samples()));
  const fs::path path = folder_ / name;
  learner.Save(path.string(), config_text);
  return path.string();
}

void CheckpointStore::DeleteBeyondKeep() {
  auto all = Checkpoints(folder_);
  for (size_t i = 0; i + keep_ < all.size(); ++i) fs::remove(all[i]);
}

std::string CheckpointStore::NewestGood(std::vector<std::string>* set_aside) {
  std::vector<std::string> damaged;
  const std::string path = FindGoodCheckpoint(run_dir_, &damaged);
  for (const auto& reason : damaged) {
    const std::string file = reason.substr(0, reason.find(": "));
    std::error_code error;
    fs::rename(file, file + ".damaged", error);
    if (set_aside) set_aside->push_back(reason);
  }
  return path;
}

}  // namespace ragdoll::learner
