#include "learner/checkpoint_store.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include "learner/learner.h"
#include "learner/trainer_config.h"

namespace ragdoll::learner {
namespace {

namespace fs = std::filesystem;

TrainerConfig TinyConfig() {
  TrainerConfig c;
  c.network.hidden_units = {4};
  c.time_horizon = 4;
  c.batch_size = c.buffer_size = 4;
  return c;
}

class CheckpointStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    run_ =
        fs::temp_directory_path() / ("ragdoll_checkpoint_store_test_" + std::to_string(::getpid()));
    fs::remove_all(run_);
  }
  void TearDown() override { fs::remove_all(run_); }

  fs::path Named(int64_t samples) const {
    char name[64];
    std::snprintf(name, sizeof(name), "checkpoint-%012lld.pt", static_cast<long long>(samples));
    return run_ / "checkpoints" / name;
  }
  // The file names in the checkpoints/ folder, sorted.
  std::vector<std::string> Files() const {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(run_ / "checkpoints")) {
      names.push_back(entry.path().filename().string());
    }
    std::sort(names.begin(), names.end());
    return names;
  }

  fs::path run_;
  Learner learner_{TinyConfig(), 3, 2};
};

TEST_F(CheckpointStoreTest, NamesACheckpointByItsSamplesAndKeepsTheNewest) {
  CheckpointStore store(run_.string(), 2);
  EXPECT_TRUE(fs::is_directory(run_ / "checkpoints"));
  EXPECT_EQ(store.Save(learner_, "config"), Named(0).string());
  EXPECT_EQ(CheckpointSamples(Named(0).string()), 0);
  for (int64_t samples : {100, 300, 200}) fs::copy_file(Named(0), Named(samples));
  EXPECT_EQ(CheckpointSamples(Named(300).string()), 300);
  EXPECT_EQ(CheckpointSamples(""), -1);
  EXPECT_EQ(Checkpoints(store.folder()),
            (std::vector<fs::path>{Named(0), Named(100), Named(200), Named(300)}));
  store.DeleteBeyondKeep();
  EXPECT_EQ(Files(),
            (std::vector<std::string>{"checkpoint-000000000200.pt", "checkpoint-000000000300.pt"}));
  EXPECT_EQ(FindCheckpoint(run_.string()), Named(300).string());
}

// A damaged newer checkpoint is renamed out of the way: the checkpoints written after resuming
// from an older one carry lower sample counts, and rotation would delete them before it.
TEST_F(CheckpointStoreTest, TheNewestGoodOneIsFoundAndTheDamagedAreSetAside) {
  CheckpointStore store(run_.string(), 2);
  store.Save(learner_, "config");
  for (int64_t samples : {100, 200, 300}) fs::copy_file(Named(0), Named(samples));
  fs::remove(Named(0));
  fs::resize_file(Named(300), fs::file_size(Named(300)) / 2);
  std::vector<std::string> set_aside;
  EXPECT_EQ(store.NewestGood(&set_aside), Named(200).string());
  ASSERT_EQ(set_aside.size(), 1u);
  EXPECT_NE(set_aside[0].find("checkpoint-000000000300.pt: truncated"), std::string::npos)
      << set_aside[0];
  EXPECT_EQ(Files(),
            (std::vector<std::string>{"checkpoint-000000000100.pt", "checkpoint-000000000200.pt",
                                      "checkpoint-000000000300.pt.damaged"}));
  // Rotation passes over the damaged file.
  fs::copy_file(Named(200), Named(250));
  store.DeleteBeyondKeep();
  EXPECT_EQ(Files(),
            (std::vector<std::string>{"checkpoint-000000000200.pt", "checkpoint-000000000250.pt",
                                      "checkpoint-000000000300.pt.damaged"}));
}

TEST_F(CheckpointStoreTest, ARunWithoutCheckpointsHasNoneToResumeFrom) {
  CheckpointStore store(run_.string(), 5);
  std::vector<std::string> set_aside;
  EXPECT_EQ(store.NewestGood(&set_aside), "");
  EXPECT_TRUE(set_aside.empty());
  EXPECT_EQ(FindCheckpoint(run_.string()), "");
}

}  // namespace
}  // namespace ragdoll::learner
