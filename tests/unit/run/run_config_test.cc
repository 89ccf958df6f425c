// config.yaml's writer and reader together: the effective configuration a run folder keeps reads
// back as the same experiment, and the run's first writer wins.
#include "common/run_config.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

#include "run/experiment.h"

namespace ragdoll::run {
namespace {

class RunConfigTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("run_config_test_" + std::to_string(getpid()));
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::filesystem::path dir_;
};

TEST_F(RunConfigTest, AShippedConfigReadsBackAsTheSameExperiment) {
  const Experiment original =
      ReadExperiment(std::string(RAGDOLL_SOURCE_DIR) + "/configs/steer_recovery.yaml");
  WriteRunConfig(dir_.string(), original.text);
  const Experiment again = ReadExperiment(RunConfigPath(dir_.string()));
  // The effective text has every path absolute, so reading it again changes nothing.
  EXPECT_EQ(again.text, original.text);
  EXPECT_EQ(again.environment.motion, original.environment.motion);
  EXPECT_EQ(again.environment.steering.motions.size(),
            original.environment.steering.motions.size());
  EXPECT_EQ(again.trainer.network.hidden_units, original.trainer.network.hidden_units);
  EXPECT_DOUBLE_EQ(again.trainer.learning_rate, original.trainer.learning_rate);
  EXPECT_EQ(ReadRunConfig(dir_.string()), original.text);
}

TEST_F(RunConfigTest, TheFirstWriterWinsUnlessTold) {
  WriteRunConfig(dir_.string(), "a: 1\n");
  WriteRunConfig(dir_.string(), "a: 2\n");
  EXPECT_EQ(ReadRunConfig(dir_.string()), "a: 1\n");
  WriteRunConfig(dir_.string(), "a: 3\n", /*replace=*/true);
  EXPECT_EQ(ReadRunConfig(dir_.string()), "a: 3\n");
  EXPECT_FALSE(std::filesystem::exists(RunConfigPath(dir_.string()) + ".tmp"));
  EXPECT_EQ(ReadRunConfig((dir_ / "missing").string()), "");
  EXPECT_THROW(WriteRunConfig((dir_ / "missing").string(), "a: 1\n"), std::exception);
}

}  // namespace
}  // namespace ragdoll::run
