#include "learner/training_log.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "learner/raw_training.h"
#include "learner/trainer_config.h"

namespace ragdoll::learner {
namespace {

namespace fs = std::filesystem;

// A fresh folder for one test's run, removed when the test ends, passed or not.
struct ScratchRun {
  explicit ScratchRun(const std::string& name)
      : path(fs::temp_directory_path() / (name + "_" + std::to_string(::getpid()))) {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~ScratchRun() { fs::remove_all(path); }
  const fs::path path;
};

std::vector<std::string> Lines(const fs::path& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::vector<std::string> Fields(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream in(line);
  for (std::string field; std::getline(in, field, ',');) fields.push_back(field);
  return fields;
}

// metrics.csv's columns are what plots and `ragdoll report` read: the header is written once per
// run (the learner's own columns, then the episode figures by name), and every row has a value
// for each column.
TEST(TrainingLog, TheLeaderWritesTheCsvHeaderOnceAndARowPerUpdate) {
  const ScratchRun scratch("ragdoll_training_log_test");
  const fs::path& run = scratch.path;
  TrainerConfig config;
  config.network.hidden_units = {4};
  Learner learner(config, 3, 2);
  learner.SetFigureNames({"rotation", "velocity", "task", "speed_error"});
  UpdateStats u;
  u.policy_loss = 0.25;
  u.samples = 32;
  for (bool leader : {true, true, false}) {
    MetricsEndpoint endpoint("learner", "127.0.0.1", -1, "test");
    TrainingLog log(endpoint, run.string(), "test", leader, learner, /*reward_terms=*/3);
    log.Updated(learner, u, 1000);
  }
  const std::vector<std::string> lines = Lines(run / "metrics.csv");
  ASSERT_EQ(lines.size(), 3u);  // the followers write none
  EXPECT_EQ(lines[0],
            "iteration,version,samples,elapsed_s,samples_per_s,episodes,mean_return,"
            "normalized_return,episode_length,fall_rate,policy_loss,value_loss,entropy,approx_kl,"
            "clip_fraction,explained_variance,learning_rate,update_s,stale_dropped,rejected,"
            "idle_fraction,update_kl,rotation,velocity,task,speed_error");
  const std::vector<std::string> columns = Fields(lines[0]);
  for (size_t i = 1; i < lines.size(); ++i) {
    const std::vector<std::string> row = Fields(lines[i]);
    ASSERT_EQ(row.size(), columns.size());
    EXPECT_EQ(row[10], "0.25");  // policy_loss
  }
}

// The learner warns when its updates run far below the same networks' plain fwd+bwd+Adam measured
// at start-up: from the third update it sees (the first ones warm caches), once for a run of slow
// updates, again after a fast one.
TEST(TrainingLog, WarnsOfUpdatesFarBelowTheNetworksOwnRate) {
  const ScratchRun run("ragdoll_training_log_warn");
  TrainerConfig config;
  config.network.hidden_units = {4};
  Learner learner(config, 3, 2);
  MetricsEndpoint endpoint("learner", "127.0.0.1", -1, "test");
  TrainingLog log(endpoint, run.path.string(), "test", true, learner, /*reward_terms=*/0);
  log.CompareUpdatesWith(/*sgemm_gflops=*/200, /*raw_gflops=*/40);
  auto warnings_after = [&](std::vector<double> gflops) {
    ::testing::internal::CaptureStderr();
    for (double g : gflops) {
      UpdateStats u;
      u.samples = 32;
      u.cpu_seconds = 2;
      u.gflop = g * u.cpu_seconds;
      log.Updated(learner, u, 1000);
    }
    const std::string err = ::testing::internal::GetCapturedStderr();
    int n = 0;
    for (size_t at = err.find("warning"); at != std::string::npos; at = err.find("warning", at + 1))
      ++n;
    return std::make_pair(n, err);
  };
  // Two slow updates first: not judged yet.
  EXPECT_EQ(warnings_after({5, 5}).first, 0);
  // 9.9 is below a quarter of 40, 10.1 is not; slow ones in a row warn once.
  const auto [slow, text] = warnings_after({9.9, 9.9, 9.9});
  EXPECT_EQ(slow, 1);
  EXPECT_NE(text.find("9.9 GFLOP/s per CPU-second, 0.25 of the same networks' plain"),
            std::string::npos)
      << text;
  EXPECT_EQ(warnings_after({10.1, 40}).first, 0);
  EXPECT_EQ(warnings_after({8}).first, 1);  // slow again after fast ones
}

// The start-up baseline trains the trainer's own networks: the same parameters as the learner's,
// and a finite rate.
TEST(RawTraining, TrainsTheLearnersNetworks) {
  TrainerConfig config;
  config.network.hidden_units = {16, 8};
  Learner learner(config, 5, 3);
  RawTraining raw(config, 5, 3, learner.minibatch_size());
  EXPECT_EQ(raw.parameters(), learner.trained_parameters());
  const double rate = raw.BestRate(3, 1.0);
  EXPECT_TRUE(std::isfinite(rate));
  EXPECT_GT(rate, 0);
}

}  // namespace
}  // namespace ragdoll::learner
