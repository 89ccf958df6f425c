// eval.json's writer and reader together: what `ragdoll eval` composes from the protocols' own
// sections reads back field by field, and files of older versions still read.
#include "eval/eval_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>

#include "common/config_section.h"
#include "eval/command_evaluation.h"
#include "eval/evaluation.h"
#include "eval/push_evaluation.h"
#include "eval/recovery_evaluation.h"
#include "tests/unit/error_of.h"

namespace ragdoll::eval {
namespace {

TEST(EvalFile, ReadsBackWhatEvalComposesFromEachProtocol) {
  EvaluationResult episodes;
  episodes.episodes = 20;
  episodes.mean_return = 25.25;
  episodes.normalized_return = 0.75;
  episodes.episode_length = 29.5;
  episodes.fall_rate = 0.25;
  episodes.spec.figure_names = {"rotation", "velocity", "end_effector", "com",
                                "root",     "task",     "speed_error"};
  episodes.spec.figure_units = {"", "", "", "", "", "", "m/s"};
  episodes.spec.reward_terms = 6;
  episodes.spec.task = "steering";
  episodes.figures = {0.5, 0.25, 0.125, 0.0625, 0.375, 0.625, 0.2};
  RobustnessResult pushes;
  pushes.results = {{50, 250, 0, 0.75}, {100, 500, 0.5, 0.5}};
  pushes.survived_90 = 50;
  PushProtocolResult protocol;
  protocol.mass = 60;
  protocol.directions = {{"forward", 90, 1.5, false, 7}, {"left", 640, 10.5, true, 12}};
  RecoveryResult recovery;
  recovery.config.trials = 4;
  recovery.config.hold = 0.5;
  recovery.times = {1.5, 2.5, -1, 4.5};
  recovery.postures = {"face up", "face down", "side", "face up"};
  recovery.within_5 = 0.75;
  recovery.within_10 = 0.75;
  recovery.median_seconds = 2.5;
  CommandEvalResult commands;
  commands.runs = 4;
  commands.knockdown_seconds = {2.0, 3.0, std::numeric_limits<double>::infinity()};
  commands.back_window = 6;

  EvaluationSections sections;
  sections.episodes = episodes.ToJson(&pushes);
  sections.push_protocol = protocol.ToJson();
  sections.recovery = recovery.ToJson();
  sections.commands = commands.ToJson();
  sections.command_script = "random";
  sections.whole_clip = {{0.5, 120, false}, {0.25, 40, true}};
  sections.checkpoint = "runs/a/checkpoints/checkpoint-000000123456.pt";
  sections.policy_version = 12;
  sections.samples = 123456;
  const EvaluationSummary s = ParseEvaluationJson(ComposeEvaluationJson(sections), "eval.json");

  EXPECT_EQ(s.episodes, 20);
  EXPECT_DOUBLE_EQ(s.mean_return, 25.25);
  EXPECT_DOUBLE_EQ(s.normalized_return, 0.75);
  EXPECT_DOUBLE_EQ(s.episode_length, 29.5);
  EXPECT_DOUBLE_EQ(s.fall_rate, 0.25);
  // The imitation terms in the environment's order, then the task's term.
  EXPECT_EQ(s.reward_terms, (std::vector<std::pair<std::string, double>>{{"rotation", 0.5},
                                                                         {"velocity", 0.25},
                                                                         {"end_effector", 0.125},
                                                                         {"com", 0.0625},
                                                                         {"root", 0.375},
                                                                         {"task", 0.625}}));
  EXPECT_EQ(s.checkpoint, sections.checkpoint);
  EXPECT_EQ(s.policy_version, 12);
  EXPECT_EQ(s.samples, 123456);
  EXPECT_TRUE(s.pushes);
  EXPECT_DOUBLE_EQ(s.survived_90, 50);
  ASSERT_EQ(s.push_directions.size(), 2u);
  EXPECT_EQ(s.push_directions[1].direction, "left");
  EXPECT_DOUBLE_EQ(s.push_directions[1].impulse, 640);
  EXPECT_DOUBLE_EQ(s.push_directions[1].velocity_change, 10.5);
  EXPECT_TRUE(s.push_directions[1].at_limit);
  EXPECT_EQ(s.recovery_trials, 4);
  EXPECT_DOUBLE_EQ(s.recovery_hold, 0.5);
  EXPECT_DOUBLE_EQ(s.within_5, 0.75);
  EXPECT_DOUBLE_EQ(s.recovery_median, 2.5);
  EXPECT_EQ(s.knockdowns, 3);
  EXPECT_DOUBLE_EQ(s.back_window, 6);
  EXPECT_DOUBLE_EQ(s.back_within, 2.0 / 3);
  EXPECT_DOUBLE_EQ(s.back_median, 3.0);
}

TEST(EvalFile, IsWrittenWholeIntoTheRunFolder) {
  const std::filesystem::path run =
      std::filesystem::temp_directory_path() / ("eval_file_test_" + std::to_string(getpid()));
  std::filesystem::create_directories(run);
  WriteEvaluationFile(run.string(), R"({"episodes": 1})");
  std::ifstream in(run / kEvaluationFile);
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()),
            "{\"episodes\": 1}\n");
  EXPECT_FALSE(std::filesystem::exists(run / "eval.json.tmp"));
  std::filesystem::remove_all(run);
  EXPECT_THROW(WriteEvaluationFile(run.string(), "{}"), std::exception);
}

TEST(EvalFile, ReadsFilesOfEveryVersion) {
  const std::string json = R"({
  "checkpoint": "runs/a/checkpoints/checkpoint-000000123456.pt",
  "episode_length": 29.5, "episodes": 20, "fall_rate": 0.05, "mean_return": 25.25,
  "normalized_return": 0.987, "policy_version": 12,
  "reward_terms": {"com": 0.9, "end_effector": 0.8, "root": 0.7, "rotation": 0.6, "velocity": 0.5},
  "samples": 123456})";
  EvaluationSummary e = ParseEvaluationJson(json, "runs/a/eval.json");
  EXPECT_EQ(e.episodes, 20);
  EXPECT_DOUBLE_EQ(e.normalized_return, 0.987);
  EXPECT_DOUBLE_EQ(e.fall_rate, 0.05);
  EXPECT_DOUBLE_EQ(e.episode_length, 29.5);
  EXPECT_EQ(e.reward_terms, (std::vector<std::pair<std::string, double>>{{"rotation", 0.6},
                                                                         {"velocity", 0.5},
                                                                         {"end_effector", 0.8},
                                                                         {"com", 0.9},
                                                                         {"root", 0.7}}));
  EXPECT_EQ(e.policy_version, 12);
  EXPECT_EQ(e.samples, 123456);
  EXPECT_EQ(e.checkpoint, "runs/a/checkpoints/checkpoint-000000123456.pt");
  EXPECT_FALSE(e.pushes);

  EvaluationSummary old = ParseEvaluationJson(
      R"({"episode_length": 30, "episodes": 5, "fall_rate": 0, "mean_return": 1,
          "normalized_return": 0.5, "perturbation": {"survived_90": 20.0},
          "reward_terms": {"com": 1, "end_effector": 1, "root": 1, "rotation": 1, "velocity": 1}})",
      "old.json");
  EXPECT_EQ(old.policy_version, -1);
  EXPECT_EQ(old.samples, -1);
  EXPECT_TRUE(old.pushes);
  EXPECT_DOUBLE_EQ(old.survived_90, 20);
  EXPECT_TRUE(old.push_directions.empty());

  EvaluationSummary pushed = ParseEvaluationJson(
      R"({"episode_length": 30, "episodes": 5, "fall_rate": 0, "mean_return": 1,
          "normalized_return": 0.5, "reward_terms": {"rotation": 1},
          "perturbation": {"survived_90": 20.0, "protocol": {"mass": 60, "directions": [
            {"direction": "forward", "survived_90": 90, "velocity_change": 1.5, "at_limit": false},
            {"direction": "left", "survived_90": 640, "velocity_change": 10.67, "at_limit": true}
          ]}}})",
      "pushed.json");
  ASSERT_EQ(pushed.push_directions.size(), 2u);
  EXPECT_EQ(pushed.push_directions[0].direction, "forward");
  EXPECT_DOUBLE_EQ(pushed.push_directions[0].impulse, 90);
  EXPECT_DOUBLE_EQ(pushed.push_directions[0].velocity_change, 1.5);
  EXPECT_TRUE(pushed.push_directions[1].at_limit);

  EXPECT_EQ(ConfigErrorOf([] {
              ParseEvaluationJson("{\"episodes\": 3", "e.json");
            }).rfind("e.json: not JSON (", 0),
            0u);
  EXPECT_EQ(ConfigErrorOf([] {
              ParseEvaluationJson("{\"episodes\": 3}", "e.json");
            }).rfind("e.json: not an evaluation written by `ragdoll eval` (", 0),
            0u);
}

}  // namespace
}  // namespace ragdoll::eval
