#include "eval/evaluation.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>
#include <fstream>
#include <limits>

#include "actor/rollout.h"
#include "common/config_section.h"
#include "common/policy.h"
#include "eval/command_evaluation.h"
#include "eval/push_evaluation.h"
#include "eval/recovery_evaluation.h"

namespace ragdoll::eval {
namespace {

// An untrained policy (outputs near zero: in offset mode, PD tracking of the reference) on the
// stand clip: it stays up for well over a second, and a huge push knocks it over.
class PushTest : public ::testing::Test {
 protected:
  PushTest() {
    env_.motion = std::string(RAGDOLL_ASSETS_DIR) + "/motions/stand.json";
    env_.character = std::string(RAGDOLL_ASSETS_DIR) + "/character/humanoid.xml";
    env_.action_mode = sim::ActionMode::kOffset;
    torch::manual_seed(3);
    actor::RolloutWorker probe(env_, 1, 1, 0, "probe");
    NetworkConfig net;
    net.hidden_units = {32};
    GaussianPolicy policy(probe.spec().observation_size, probe.spec().action_size, net);
    snapshot_ = MakeSnapshot(policy, RunningStats(probe.spec().observation_size), 7, 0);
    push_.settle = 0.2;
    push_.observe = 0.4;
    push_.trials = 6;
    push_.impulses = {0, 400};
  }
  sim::EnvConfig env_;
  v1::PolicySnapshot snapshot_;
  PushConfig push_;
};

TEST_F(PushTest, AHardPushFellsTheCharacterAndNoPushDoesNot) {
  push_.observe = 1.0;  // long enough to land: flying away from the reference is no fall
  RobustnessResult r = EvaluatePushes(env_, snapshot_, push_, 11);
  ASSERT_EQ(r.results.size(), 2u);
  EXPECT_EQ(r.results[0].fall_rate, 0.0);
  EXPECT_EQ(r.results[1].fall_rate, 1.0);  // 4000 N on the pelvis for 0.1 s
  EXPECT_DOUBLE_EQ(r.results[1].force, 400 / 0.1);
  EXPECT_EQ(r.survived_90, 0.0);
  // The same seed gives the same trials.
  RobustnessResult again = EvaluatePushes(env_, snapshot_, push_, 11);
  EXPECT_EQ(again.results[0].normalized_return, r.results[0].normalized_return);
  EXPECT_EQ(again.results[1].normalized_return, r.results[1].normalized_return);
  EXPECT_NE(r.ToTable().find("largest push survived in >= 90 % of trials: 0.0 N s"),
            std::string::npos)
      << r.ToTable();
  EvaluationResult e;
  EXPECT_NE(e.ToJson(&r).find("\"survived_90\": 0.0"), std::string::npos);
}

TEST_F(PushTest, RejectsUnknownBodiesAndDirections) {
  push_.body = "tail";
  EXPECT_THROW(EvaluatePushes(env_, snapshot_, push_, 1), ConfigError);
  push_.body = "root";
  push_.direction = "up";
  EXPECT_THROW(EvaluatePushes(env_, snapshot_, push_, 1), ConfigError);
  PushProtocolConfig protocol;
  protocol.directions = {"forward", "random"};  // the protocol's directions are of the heading
  EXPECT_THROW(EvaluatePushProtocol(env_, snapshot_, protocol, 1), ConfigError);
  protocol.directions = {"left"};
  protocol.resolution = 0;
  EXPECT_THROW(EvaluatePushProtocol(env_, snapshot_, protocol, 1), ConfigError);
}

// DeepMimic's protocol finds, per direction, an impulse the character survives (the sweep at that
// impulse agrees) within the resolution of one it does not, and divides it by the character's
// mass; the same seed gives the same search.
TEST_F(PushTest, TheProtocolBisectsToTheLargestImpulseSurvivedPerDirection) {
  PushProtocolConfig protocol;
  protocol.trials = 5;  // no fall allowed
  protocol.settle = 0.2;
  protocol.observe = 0.6;
  protocol.resolution = 8;
  protocol.directions = {"forward", "left"};
  const PushProtocolResult r = EvaluatePushProtocol(env_, snapshot_, protocol, 5);
  const auto character = character::Character::Load(env_.character, env_.physics_dt());
  double mass = 0;
  for (int b = 1; b < character->model()->nbody; ++b) mass += character->model()->body_mass[b];
  EXPECT_NEAR(r.mass, mass, 1e-9);
  ASSERT_EQ(r.directions.size(), 2u);
  for (const DirectionResult& d : r.directions) {
    SCOPED_TRACE(d.direction);
    EXPECT_FALSE(d.at_limit);
    EXPECT_GE(d.survived_90, protocol.start);  // the untrained policy stands a 10 N s push
    EXPECT_DOUBLE_EQ(d.velocity_change, d.survived_90 / mass);
    // Doubling from 10 N s to the first failure F, then halving [F / 2, F] to 8 N s.
    const int doublings = static_cast<int>(std::floor(std::log2(d.survived_90 / 10))) + 2;
    EXPECT_LE(d.impulses_tried,
              doublings +
                  static_cast<int>(std::ceil(std::log2(d.survived_90 / protocol.resolution))) + 1);
    PushConfig sweep;
    sweep.impulses = {d.survived_90};
    sweep.duration = protocol.duration;
    sweep.trials = protocol.trials;
    sweep.settle = protocol.settle;
    sweep.observe = protocol.observe;
    sweep.direction = d.direction;
    EXPECT_EQ(EvaluatePushes(env_, snapshot_, sweep, 5).results[0].fall_rate, 0.0);
  }
  const PushProtocolResult again = EvaluatePushProtocol(env_, snapshot_, protocol, 5);
  EXPECT_EQ(again.directions[1].survived_90, r.directions[1].survived_90);
  EXPECT_NE(r.ToTable().find("left"), std::string::npos) << r.ToTable();
  EXPECT_NE(r.ToJson().find("\"velocity_change\""), std::string::npos);
}

// A figure found with few trials a step is a single draw: the table says so, and how to narrow it.
TEST(PushProtocolTableTest, FewTrialsCarryACaution) {
  PushProtocolResult r;
  r.mass = 60;
  r.directions.push_back({"backward", 80, 80.0 / 60, false, 9});
  r.config.trials = 20;
  EXPECT_NE(r.ToTable().find("20 trials a step"), std::string::npos) << r.ToTable();
  EXPECT_NE(r.ToTable().find("--push-trials 100"), std::string::npos) << r.ToTable();
  r.config.trials = 100;
  EXPECT_EQ(r.ToTable().find("trials a step"), std::string::npos) << r.ToTable();
}

// An untrained policy does not get up: every trial is timed as never, the shares are 0, and the
// table and JSON say so; each trial names how the character lay.
TEST_F(PushTest, AnUntrainedPolicyDoesNotGetUpFromAFall) {
  RecoveryConfig recovery;
  recovery.trials = 3;
  recovery.seconds = 2;
  const RecoveryResult r = EvaluateRecovery(env_, snapshot_, recovery, 4);
  EXPECT_EQ(r.times, (std::vector<double>{-1, -1, -1}));
  EXPECT_EQ(r.within_5, 0);
  EXPECT_EQ(r.within_10, 0);
  EXPECT_EQ(r.median_seconds, -1);
  ASSERT_EQ(r.postures.size(), 3u);
  for (const auto& p : r.postures)
    EXPECT_TRUE(p == "face down" || p == "face up" || p == "side") << p;
  EXPECT_NE(r.ToTable().find("within 10 s 0 %, median time never"), std::string::npos)
      << r.ToTable();
  EXPECT_NE(r.ToJson().find("\"within_10\": 0.0"), std::string::npos) << r.ToJson();
  recovery.trials = 0;
  EXPECT_THROW(EvaluateRecovery(env_, snapshot_, recovery, 4), ConfigError);
}

// Scripted commands on a set of two clips that both stand still: "stand" demonstrates standing,
// "still" claims a 0.5 m/s walk. A policy of zero weights (PD tracking of the reference) stands, so
// its speed error is ~0 under "stand" and ~0.5 m/s under "still", and only the change back to
// "stand" succeeds.
class CommandEvalTest : public ::testing::Test {
 protected:
  CommandEvalTest() {
    const std::string stand = std::string(RAGDOLL_ASSETS_DIR) + "/motions/stand.json";
    env_.character = std::string(RAGDOLL_ASSETS_DIR) + "/character/humanoid.xml";
    env_.action_mode = sim::ActionMode::kOffset;
    sim::MotionSetItem item;
    item.motion = stand;
    item.name = "stand";
    env_.steering.motions.push_back(item);
    item.name = "still";
    item.command_from_clip = false;
    item.command = {0.5, 0, 0};
    env_.steering.motions.push_back(item);
    env_.motion = stand;
    torch::manual_seed(3);
    actor::RolloutWorker probe(env_, 1, 1, 0, "probe");
    NetworkConfig net;
    net.hidden_units = {32};
    GaussianPolicy policy(probe.spec().observation_size, probe.spec().action_size, net);
    // Zero weights: the mean action is 0, i.e. PD tracking of the reference pose exactly.
    {
      torch::NoGradGuard no_grad;
      for (auto& p : policy->parameters()) p.zero_();
    }
    snapshot_ = MakeSnapshot(policy, RunningStats(probe.spec().observation_size), 7, 0);
    character_ = character::Character::Load(env_.character, env_.physics_dt());
    motions_ = sim::LoadMotionSet(env_, *character_);
  }
  std::string Script(const std::string& text) {
    // One file per test and call: ctest runs the tests as processes side by side.
    const std::string path = ::testing::TempDir() + "/" +
                             ::testing::UnitTest::GetInstance()->current_test_info()->name() + "-" +
                             std::to_string(scripts_++) + ".yaml";
    std::ofstream(path) << text;
    return path;
  }
  int scripts_ = 0;
  sim::EnvConfig env_;
  v1::PolicySnapshot snapshot_;
  std::shared_ptr<const character::Character> character_;
  std::shared_ptr<const sim::MotionSet> motions_;
};

TEST_F(CommandEvalTest, ScoresTrackingPerCommandAndTransitions) {
  // PD tracking alone keeps the ragdoll up for about two seconds: a short script, with tracking
  // scored 0.25 s after each change and transitions judged over 0.25-0.6 s.
  CommandEvalConfig c;
  c.random = false;
  c.runs = 2;
  c.settle = 0.25;
  c.transition_window = 0.6;
  c.script = ReadCommandScript(Script("duration: 1.8\ncommands:\n  - {at: 0, command: stand}\n"
                                      "  - {at: 0.6, command: still}\n"
                                      "  - {at: 1.2, command: stand}\n"),
                               *motions_, *character_);
  ASSERT_EQ(c.script.changes.size(), 3u);
  CommandEvalResult r = EvaluateCommands(env_, snapshot_, c, 5);
  ASSERT_EQ(r.falls, 0) << r.ToTable();
  EXPECT_EQ(r.runs, 2);
  EXPECT_NEAR(r.seconds, 3.6, 1e-6);
  // Settled per run: 0.35 s of "stand" in each of its two spells, 0.35 s of "still".
  EXPECT_NEAR(r.per_command.at("stand").seconds, 2 * 0.7, 0.07);
  EXPECT_NEAR(r.per_command.at("still").seconds, 2 * 0.35, 0.07);
  EXPECT_LT(r.per_command.at("stand").speed_error, 0.1) << r.ToTable();
  EXPECT_NEAR(r.per_command.at("still").speed_error, 0.5, 0.1) << r.ToTable();
  EXPECT_LT(r.per_command.at("stand").heading_error, 0.1);
  EXPECT_GT(r.per_command.at("stand").imitation, 0.5);
  EXPECT_NEAR(r.moving.seconds, r.per_command.at("still").seconds, 1e-9);
  ASSERT_EQ(r.transitions.size(), 2u) << r.ToTable();
  EXPECT_EQ(r.transitions.at("stand->still").count, 2);
  EXPECT_EQ(r.transitions.at("stand->still").succeeded, 0);
  EXPECT_EQ(r.transitions.at("still->stand").succeeded, 2);
  EXPECT_NE(r.ToJson().find("\"stand->still\""), std::string::npos);
  EXPECT_NE(r.ToTable().find("fall rate 0.000"), std::string::npos) << r.ToTable();
}

// Pushes while a script plays: every 0.5 s of a 1.8 s script (at 0.5, 1.0 and 1.5 s); impulses of
// at most 0 N s change nothing, of up to 400 N s on the pelvis fell the character.
TEST_F(CommandEvalTest, PushesDuringAScriptAreCountedAndKnockTheCharacterDown) {
  CommandEvalConfig c;
  c.random = false;
  c.runs = 2;
  c.script = ReadCommandScript(Script("duration: 1.8\ncommands:\n  - {at: 0, command: stand}\n"),
                               *motions_, *character_);
  c.push_interval = 0.5;
  c.push_max = 0;
  const CommandEvalResult calm = EvaluateCommands(env_, snapshot_, c, 5);
  EXPECT_EQ(calm.pushes, 6);
  EXPECT_EQ(calm.falls, 0) << calm.ToTable();
  EXPECT_EQ(calm.knocked_down, 0);
  c.push_max = 400;
  const CommandEvalResult hard = EvaluateCommands(env_, snapshot_, c, 5);
  EXPECT_EQ(hard.falls, 2) << hard.ToTable();
  EXPECT_EQ(hard.knocked_down, 2);
  EXPECT_GE(hard.pushes, 2);
  EXPECT_LT(hard.seconds, calm.seconds);
  EXPECT_NE(hard.ToTable().find("2 runs knocked down, 2 of them did not get up"), std::string::npos)
      << hard.ToTable();
  EXPECT_NE(hard.ToJson().find("\"knocked_down\": 2"), std::string::npos);
}

// A script's own pushes: one of 400 N s at 0.5 s fells the character, one of 0 N s changes
// nothing; the caption names the push while it lasts and a while after.
TEST_F(CommandEvalTest, AScriptsPushesAreGivenAtTheirTimes) {
  CommandEvalConfig c;
  c.random = false;
  c.runs = 1;
  const std::string head = "duration: 1.8\ncommands:\n  - {at: 0, command: stand}\npushes:\n";
  c.script = ReadCommandScript(Script(head + "  - {at: 0.5, impulse: 0, direction: left}\n"),
                               *motions_, *character_);
  ASSERT_EQ(c.script.pushes.size(), 1u);
  EXPECT_EQ(c.script.pushes[0].duration, 0.2);
  EXPECT_EQ(EvaluateCommands(env_, snapshot_, c, 5).falls, 0);
  c.script = ReadCommandScript(
      Script(head + "  - {at: 0.5, impulse: 400, direction: left, body: chest}\n"), *motions_,
      *character_);
  const CommandEvalResult r = EvaluateCommands(env_, snapshot_, c, 5);
  EXPECT_EQ(r.falls, 1) << r.ToTable();
  EXPECT_EQ(r.pushes, 1);
  EXPECT_LT(r.seconds, 1.5);

  sim::ImitationEnv env(character_, motions_, env_, 1);
  std::vector<float> obs(env.spec().observation_size);
  env.Reset(obs.data());
  ScriptedPushes pushes(c.script.pushes, *character_);
  EXPECT_FALSE(pushes.Before(env, 0.4));
  EXPECT_EQ(pushes.Describe(0.4, 1.0), "");
  EXPECT_TRUE(pushes.Before(env, 0.5));
  const int chest = mj_name2id(character_->model(), mjOBJ_BODY, "chest");
  const double* f = env.data().xfrc_applied + 6 * chest;
  EXPECT_NEAR(std::hypot(f[0], f[1]), 400 / 0.2, 1e-9);
  // Left of where the character faces: 90 degrees counter-clockwise of its heading.
  EXPECT_NEAR(std::atan2(f[1], f[0]), character::WrapAngle(env.heading() + M_PI / 2), 1e-9);
  EXPECT_EQ(pushes.Describe(0.6, 1.0), "push 400 N s left");
  EXPECT_FALSE(pushes.Before(env, 0.7));
  EXPECT_EQ(f[0], 0.0);
  EXPECT_EQ(f[1], 0.0);
  EXPECT_EQ(pushes.Describe(1.6, 1.0), "push 400 N s left");
  EXPECT_EQ(pushes.Describe(1.8, 1.0), "");
  TimedPush up;
  up.direction = "up";
  EXPECT_THROW(ScriptedPushes({up}, *character_), ConfigError);
}

// Random pushes at 30 Hz every 1 s: started at steps 30 and 60, each 6 steps (0.2 s) long, of the
// fixed impulse when its range is one value, toward angles the seed repeats; none when every <= 0.
TEST_F(CommandEvalTest, RandomPushesComeOnTimeAndLastTheirTime) {
  sim::ImitationEnv env(character_, motions_, env_, 1);
  std::vector<float> obs(env.spec().observation_size);
  env.Reset(obs.data());
  const int pelvis = character_->root_body();
  const double* f = env.data().xfrc_applied + 6 * pelvis;
  RandomPushes a(40, 40, 1.0, 1.0 / 30, 7, pelvis), b(40, 40, 1.0, 1.0 / 30, 7, pelvis);
  std::vector<int> started, pushing;
  std::vector<double> angles;
  for (int step = 0; step < 75; ++step) {
    if (a.Before(env, step)) {
      started.push_back(step);
      angles.push_back(a.last_angle());
      EXPECT_EQ(a.last_impulse(), 40);
      EXPECT_NEAR(std::hypot(f[0], f[1]), 40 / 0.2, 1e-9);
      EXPECT_NEAR(std::atan2(f[1], f[0]), character::WrapAngle(a.last_angle()), 1e-9);
    }
    if (std::hypot(f[0], f[1]) > 0) pushing.push_back(step);
  }
  EXPECT_EQ(started, (std::vector<int>{30, 60}));
  EXPECT_EQ(pushing, (std::vector<int>{30, 31, 32, 33, 34, 35, 60, 61, 62, 63, 64, 65}));
  EXPECT_EQ(a.count(), 2);
  for (int step = 0; step <= 30; ++step) b.Before(env, step);
  EXPECT_EQ(b.last_angle(), angles[0]);
  RandomPushes none(40, 40, 0, 1.0 / 30, 7, pelvis);
  for (int step = 0; step < 75; ++step) EXPECT_FALSE(none.Before(env, step));
}

// Push trials on a steered character hold the command they are given; one the set does not
// have, or a command for a run without steering, is refused by name.
TEST_F(CommandEvalTest, PushTrialsHoldTheirCommand) {
  PushConfig push;
  push.impulses = {0};
  push.trials = 1;
  push.command = "still";
  const RobustnessResult held = EvaluatePushes(env_, snapshot_, push, 3);
  ASSERT_EQ(held.results.size(), 1u);
  EXPECT_EQ(held.config.command, "still");
  push.command = "fly";
  EXPECT_THAT([&] { EvaluatePushes(env_, snapshot_, push, 3); },
              ::testing::ThrowsMessage<ConfigError>(::testing::HasSubstr(
                  "push command 'fly': not a command of the run's motion set")));
  sim::EnvConfig plain = env_;
  plain.steering.motions.clear();
  PushProtocolConfig protocol;
  protocol.command = "walk";
  EXPECT_THAT([&] { EvaluatePushProtocol(plain, snapshot_, protocol, 3); },
              ::testing::ThrowsMessage<ConfigError>(::testing::HasSubstr("no steering task")));
}

TEST_F(CommandEvalTest, RandomScriptsAreSeededAndChangeTheCommand) {
  CommandScript a = RandomCommandScript(*motions_, 60, 2, 5, 9);
  CommandScript b = RandomCommandScript(*motions_, 60, 2, 5, 9);
  ASSERT_EQ(a.changes.size(), b.changes.size());
  EXPECT_GE(a.changes.size(), 12u);  // 60 s at one change per 2-5 s
  EXPECT_LE(a.changes.size(), 31u);
  for (size_t i = 0; i < a.changes.size(); ++i) {
    EXPECT_EQ(a.changes[i].at, b.changes[i].at);
    EXPECT_EQ(a.changes[i].command, b.changes[i].command);
    if (i > 0) {
      EXPECT_NE(a.changes[i].command, a.changes[i - 1].command);
    }
  }
  EXPECT_EQ(a.changes.front().at, 0.0);
}

TEST_F(CommandEvalTest, BadScriptsNameFileLineAndProblem) {
  auto error = [&](const std::string& text) {
    try {
      ReadCommandScript(Script(text), *motions_, *character_);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error("commands:\n  - {at: 0, command: fly}\n")
                .find("-0.yaml:2: commands[0].command: "
                      "'fly' is not a command of the run's "
                      "motion set (stand, still)"),
            std::string::npos);
  EXPECT_NE(error("commands:\n  - {at: 1, command: stand}\n").find("the first command starts at 0"),
            std::string::npos);
  EXPECT_NE(error("commands:\n  - {at: 0, command: stand}\n  - {at: 0, command: still}\n")
                .find("times must increase"),
            std::string::npos);
  EXPECT_NE(
      error("duration: 1\ncommands:\n  - {at: 0, command: stand}\n  - {at: 2, command: still}\n")
          .find("duration: must be after"),
      std::string::npos);
  const std::string stand = "commands:\n  - {at: 0, command: stand}\npushes:\n";
  EXPECT_NE(error(stand + "  - {at: 1, impulse: 50, direction: up}\n")
                .find("pushes[0].direction: 'up': one of forward, backward, left, right"),
            std::string::npos);
  EXPECT_NE(error(stand + "  - {at: 1, impulse: -5}\n").find("pushes[0].impulse"),
            std::string::npos);
  EXPECT_NE(error(stand + "  - {at: 1, impulse: 50, body: tail}\n")
                .find("pushes[0].body: 'tail' is not a body"),
            std::string::npos);
  EXPECT_NE(error(stand + "  - {at: 1, impulse: 50}\n  - {at: 1.1, impulse: 50}\n")
                .find("pushes[1].at: pushes must come in time order"),
            std::string::npos);
  EXPECT_NE(error(stand + "  - {at: 1, impulse: 50, strength: 3}\n").find("strength"),
            std::string::npos);
  sim::EnvConfig plain = env_;
  plain.steering.motions.clear();
  EXPECT_THROW(EvaluateCommands(plain, snapshot_, CommandEvalConfig(), 1), std::invalid_argument);
}

// Time from a knock-down until back on command, steps of 0.1 s: from the push that felled it,
// through a second fall, to the start of a full second of tracking; a knock-down still open when
// the run ends counts only once the window has passed, or when the episode gave up.
TEST(KnockDownClockTest, TimesFromTheKnockToASecondBackOnCommand) {
  KnockDownClock clock(0.25, 0.44, 1.0);
  double t = 0;
  // Steps up to `until`, all alike.
  auto steps = [&](double until, bool getting_up, double speed_error) {
    while (t < until - 1e-9) {
      t += 0.1;
      clock.Step(t, false, getting_up, speed_error, 0.1);
    }
  };
  steps(2.0, false, 0.1);
  clock.Pushed(2.0);
  steps(2.5, false, 0.6);
  t += 0.1;
  clock.Step(t, /*fell=*/true, true, 2.0, 0.1);  // 0.6 s after the push: the knock counts
  steps(5.0, true, 2.0);
  steps(5.5, false, 0.1);  // half a second back on command, then off it, and down again
  steps(5.7, false, 0.4);
  t += 0.1;
  clock.Step(t, true, true, 2.0, 0.1);
  steps(7.0, true, 2.0);
  steps(7.9, false, 0.1);
  EXPECT_TRUE(clock.seconds().empty());
  steps(8.0, false, 0.1);  // the tenth tracked step: a full second from 7.0, back since 7.0
  ASSERT_EQ(clock.seconds().size(), 1u);
  EXPECT_NEAR(clock.seconds()[0], 7.0 - 2.0, 1e-9);

  clock.Pushed(10.0);
  steps(12.0, false, 0.1);
  t += 0.1;
  clock.Step(t, true, true, 2.0, 0.1);  // 2.1 s after the push: timed from the fall
  steps(13.0, true, 2.0);
  steps(14.0, false, 0.1);
  ASSERT_EQ(clock.seconds().size(), 2u);
  EXPECT_NEAR(clock.seconds()[1], 13.0 - 12.1, 1e-9);

  t += 0.1;
  clock.Step(t, true, true, 2.0, 0.1);
  steps(16.0, true, 2.0);
  clock.End(t, 6.0, false);  // 1.9 s down: too soon to tell
  EXPECT_EQ(clock.seconds().size(), 2u);

  KnockDownClock gave_up(0.25, 0.44, 1.0);
  gave_up.Step(0.1, true, true, 2.0, 0.1);
  gave_up.End(0.2, 6.0, true);
  ASSERT_EQ(gave_up.seconds().size(), 1u);
  EXPECT_TRUE(std::isinf(gave_up.seconds()[0]));

  CommandEvalResult r;
  r.knockdown_seconds = {4.0, 8.0, std::numeric_limits<double>::infinity()};
  EXPECT_EQ(r.back_within(), 1);
  EXPECT_NEAR(r.median_back_seconds(), 8.0, 1e-12);
  EXPECT_NE(r.ToTable().find("3 knock-downs, back on command within 6 s: 1 (0.33), median 8.00 s"),
            std::string::npos)
      << r.ToTable();
  EXPECT_NE(r.ToJson().find("\"share_back_within\": 0.333"), std::string::npos) << r.ToJson();
  r.knockdown_seconds = {4.0, std::numeric_limits<double>::infinity()};
  EXPECT_NE(r.ToTable().find("median never"), std::string::npos) << r.ToTable();
  EXPECT_NE(r.ToJson().find("\"median_seconds\": null"), std::string::npos) << r.ToJson();
}

}  // namespace
}  // namespace ragdoll::eval
