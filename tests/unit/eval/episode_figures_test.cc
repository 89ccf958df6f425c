// A new episode figure is added in one place, the task that computes it, and reaches the
// rollout's episode summaries, the learner's sums and metrics.csv row, and the evaluation JSON
// by its name.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <algorithm>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "actor/rollout.h"
#include "common/policy.h"
#include "common/wire.h"
#include "eval/evaluation.h"
#include "learner/learner.h"
#include "learner/training_log.h"
#include "sim/task.h"

namespace ragdoll {
namespace {

// The test's task: nothing observed, no reward, one figure: the root's mean height, m.
class RootHeightTask final : public sim::Task {
 public:
  std::string name() const override { return "balance"; }
  std::vector<sim::FigureSpec> FigureSpecs() const override { return {{"root_height", "m"}}; }
  void Start(sim::TaskHost& /*env*/, std::mt19937_64& /*rng*/) override { sum_ = 0; }
  double Reward(const sim::TaskHost& env, const sim::PoseFeatures& /*character*/) override {
    sum_ += env.data().qpos[2];
    return 0;
  }
  void Figures(double steps, double* out) const override { out[0] = sum_ / steps; }

 private:
  double sum_ = 0;
};

TEST(EpisodeFigures, ATasksFigureReachesTheSummaryTheLearnerAndTheEvaluation) {
  sim::EnvConfig env;
  env.character = std::string(RAGDOLL_ASSETS_DIR) + "/character/humanoid.xml";
  env.motion = std::string(RAGDOLL_ASSETS_DIR) + "/motions/stand.json";
  env.action_mode = sim::ActionMode::kOffset;
  env.max_episode_steps = 20;
  actor::RolloutWorker worker(env, 2, 45, 5, "figures",
                              [] { return std::make_unique<RootHeightTask>(); });
  const sim::EnvSpec& spec = worker.spec();
  ASSERT_EQ(spec.figure_names, (std::vector<std::string>{"rotation", "velocity", "end_effector",
                                                         "com", "root", "root_height"}));
  EXPECT_EQ(spec.reward_terms, 5);
  torch::manual_seed(1);
  NetworkConfig net;
  net.hidden_units = {16};
  GaussianPolicy policy(spec.observation_size, spec.action_size, net);
  worker.SetPolicy(MakeSnapshot(policy, RunningStats(spec.observation_size), 1, 0));

  // The rollout: each finished episode's summary carries the figure by name.
  learner::EpisodeStatsSum sums(spec.figure_names);
  double height_sum = 0;
  for (const v1::TrajectorySegment& segment : worker.Collect()) {
    EXPECT_TRUE(wire::CheckSegment(segment, spec.observation_size, spec.action_size).ok());
    for (const v1::EpisodeSummary& e : segment.episodes()) {
      ASSERT_EQ(e.figures_size(), 6);
      EXPECT_EQ(e.figures(5).name(), "root_height");
      EXPECT_GT(e.figures(5).value(), 0.5);  // the pelvis of a standing character, m
      EXPECT_LT(e.figures(5).value(), 1.5);
      height_sum += e.figures(5).value();
      sums.Add(e);
    }
  }
  ASSERT_GE(sums.episodes, 4);  // two environments, 45 steps, episodes of 20

  // The learner's sums and its metrics.csv: a column of that name holds the mean.
  EXPECT_DOUBLE_EQ(sums.figures[5], height_sum);
  const std::vector<std::string> columns = learner::MetricsColumns(spec.figure_names);
  const size_t column = std::find(columns.begin(), columns.end(), "root_height") - columns.begin();
  ASSERT_LT(column, columns.size());
  std::map<std::string, std::string> cells;
  for (size_t i = 0; i < sums.figures.size(); ++i) {
    cells[sums.figure_names[i]] = std::to_string(sums.Mean(sums.figures[i]));
  }
  const std::string row = learner::MetricsRow(columns, cells);
  std::vector<std::string> values;
  for (size_t start = 0;;) {
    const size_t comma = row.find(',', start);
    values.push_back(row.substr(start, comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  ASSERT_EQ(values.size(), columns.size());
  EXPECT_NEAR(std::stod(values[column]), height_sum / sums.episodes, 1e-5);

  // The evaluation: the task's figures under its name, the reward terms apart.
  const eval::EvaluationResult result = eval::Evaluate(worker, 2);
  const nlohmann::json j = nlohmann::json::parse(result.ToJson());
  EXPECT_GT(j.at("balance").at("root_height").get<double>(), 0.5);
  EXPECT_EQ(j.at("reward_terms").size(), 5u);
  EXPECT_FALSE(j.at("reward_terms").contains("root_height"));
}

}  // namespace
}  // namespace ragdoll
