#include "learner/training_log.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "learner/trainer_config.h"

namespace ragdoll::learner {
namespace {

namespace fs = std::filesystem;

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
  const fs::path run =
      fs::temp_directory_path() / ("ragdoll_training_log_test_" + std::to_string(::getpid()));
  fs::remove_all(run);
  fs::create_directories(run);
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
  fs::remove_all(run);
}

}  // namespace
}  // namespace ragdoll::learner
