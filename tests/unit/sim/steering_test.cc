// The steering task: motion sets (commands measured from clips, mirroring), its config, and the
// environment's command, task reward, observation and reference switching.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <random>

#include "character/motion_io.h"
#include "common/config_section.h"
#include "sim/env_config.h"
#include "sim/imitation_env.h"
#include "sim/motion_set.h"
#include "sim/observation.h"
#include "sim/steering_task.h"
#include "tests/unit/error_of.h"
#include "tests/unit/sim/turned_clip.h"

namespace ragdoll::sim {
namespace {

const std::string kAssets = RAGDOLL_ASSETS_DIR;

EnvConfig Read(const std::string& yaml) {
  ConfigSection root = ConfigSection::FromString(yaml, "steer.yaml");
  return ReadEnvConfig(root.Section("environment"), kAssets + "/character/humanoid.xml");
}

const std::string kStand = kAssets + "/motions/stand.json";
const std::string kWalk = kAssets + "/motions/walk.json";

// A clip of `frames` poses of stand.json that does not loop: a stand-to-stand "transition".
std::shared_ptr<const character::MotionClip> StandTransition() {
  character::MotionClip stand = character::LoadMotion(kStand);
  std::vector<character::Pose> frames;
  std::vector<double> durations;
  for (int f = 0; f < 30; ++f) {
    frames.push_back(stand.frame(f % stand.num_frames()));
    durations.push_back(1.0 / 30);
  }
  return std::make_shared<const character::MotionClip>("start", false, durations, frames);
}

TEST(MotionSetTest, CommandsAreMeasuredFromTheClips) {
  Command walk = MeasureCommand(character::LoadMotion(kWalk));
  EXPECT_NEAR(walk.forward, 0.9, 1e-6);  // 0.9 m strides at one per second
  EXPECT_NEAR(walk.left, 0.0, 1e-9);
  EXPECT_NEAR(walk.turn, 0.0, 1e-9);
  Command stand = MeasureCommand(character::LoadMotion(kStand));
  EXPECT_NEAR(std::hypot(stand.forward, stand.left), 0.0, 1e-9);

  // The walk turned by 90 degrees: it walks to the world's +y but still forward in its own frame.
  character::MotionClip straight = character::LoadMotion(kWalk);
  Command turned = MeasureCommand(TurnedClip(straight, M_PI / 2, "turned"));
  EXPECT_NEAR(turned.forward, 0.9, 1e-6);
  EXPECT_NEAR(turned.left, 0.0, 1e-6);

  // A root turning at a steady rate in place: 90 degrees in one second.
  std::vector<character::Pose> turning;
  for (int f = 0; f <= 30; ++f) {
    character::Pose p = straight.frame(0);
    p.root_position = {0, 0, p.root_position[2]};
    p.root_rotation = character::AxisAngle({0, 0, 1}, M_PI / 2 * f / 30);
    turning.push_back(p);
  }
  Command turn = MeasureCommand(
      character::MotionClip("turn", false, std::vector<double>(31, 1.0 / 30), turning));
  EXPECT_NEAR(turn.turn, M_PI / 2, 1e-9);
  EXPECT_NEAR(turn.forward, 0.0, 1e-12);
}

TEST(MotionSetTest, MirrorSwapsSidesAndReflectsTheSagittalPlane) {
  auto character = character::Character::Load(kAssets + "/character/humanoid.xml");
  character::MotionClip walk = character::LoadMotion(kWalk);
  character::MotionClip mirrored = Mirror(walk, *character, "walk_mirrored");
  EXPECT_EQ(mirrored.name(), "walk_mirrored");
  ASSERT_EQ(mirrored.num_frames(), walk.num_frames());
  const auto& joints = character->joints();
  auto index = [&](const std::string& name) {
    for (size_t j = 0; j < joints.size(); ++j) {
      if (joints[j].name == name) return static_cast<int>(j);
    }
    return -1;
  };
  const int right_hip = index("right_hip"), left_hip = index("left_hip"), chest = index("chest");
  for (int f = 0; f < walk.num_frames(); f += 7) {
    const character::Pose &a = walk.frame(f), &b = mirrored.frame(f);
    EXPECT_DOUBLE_EQ(b.root_position[1], -a.root_position[1]);
    const character::Quat& l = a.joint_rotations[left_hip];
    const character::Quat& r = b.joint_rotations[right_hip];
    EXPECT_DOUBLE_EQ(r[0], l[0]);
    EXPECT_DOUBLE_EQ(r[1], -l[1]);
    EXPECT_DOUBLE_EQ(r[2], l[2]);
    EXPECT_DOUBLE_EQ(r[3], -l[3]);
    // The chest's twist (about z) against the arms' swing changes sign.
    EXPECT_DOUBLE_EQ(b.joint_rotations[chest][3], -a.joint_rotations[chest][3]);
  }
  // Twice is the original.
  character::MotionClip twice = Mirror(mirrored, *character, "walk");
  for (int f = 0; f < walk.num_frames(); ++f) {
    for (size_t j = 0; j < joints.size(); ++j) {
      EXPECT_LT(character::AngleBetween(twice.frame(f).joint_rotations[j],
                                        walk.frame(f).joint_rotations[j]),
                1e-12);
    }
  }
  // Walking straight ahead stays straight ahead.
  Command c = MeasureCommand(mirrored);
  EXPECT_NEAR(c.forward, 0.9, 1e-6);
  EXPECT_NEAR(c.left, 0.0, 1e-9);
}

TEST(SteeringConfigTest, ReadsTheMotionSet) {
  EnvConfig c = Read(R"(
environment:
  steering:
    motions:
      - motion: )" + kStand +
                     R"(
      - motion: )" + kWalk +
                     R"(
      - {motion: )" + kWalk +
                     R"(, mirror: true}
      - {motion: )" + kWalk +
                     R"(, name: slow, command: {forward: 0.5, turn: 30}}
    command_interval: {min: 1, max: 3}
    task: {velocity_weight: 0.4, heading_scale: 3}
)");
  const SteeringConfig& s = c.steering;
  ASSERT_TRUE(s.enabled());
  ASSERT_EQ(s.motions.size(), 4u);
  EXPECT_EQ(s.motions[0].name, "stand");
  EXPECT_EQ(s.motions[2].name, "walk_mirrored");
  EXPECT_TRUE(s.motions[2].mirror);
  EXPECT_FALSE(s.motions[3].command_from_clip);
  EXPECT_DOUBLE_EQ(s.motions[3].command.forward, 0.5);
  EXPECT_DOUBLE_EQ(s.motions[3].command.turn, M_PI / 6);  // degrees per second in the file
  EXPECT_DOUBLE_EQ(s.command_interval_min, 1);
  EXPECT_DOUBLE_EQ(s.command_interval_max, 3);
  EXPECT_DOUBLE_EQ(s.velocity_weight, 0.4);
  EXPECT_DOUBLE_EQ(s.heading_weight, 0.2);
  EXPECT_DOUBLE_EQ(s.heading_scale, 3);
  EXPECT_EQ(c.motion, kStand);  // tools that show "the clip" show the first
}

TEST(SteeringConfigTest, BadMotionSetsNameTheProblem) {
  const std::string head = "environment:\n  steering:\n    motions:\n";
  EXPECT_NE(ErrorOf([&] {
              Read("environment:\n  motion: " + kWalk +
                   "\n  steering:\n    motions:\n      - motion: " + kWalk + "\n");
            }).find("remove `motion`"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] {
              Read(head + "      - motion: " + kWalk + "\n      - motion: " + kWalk + "\n");
            }).find("steering.motions[1].name: 'walk' names two clips"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] {
              Read(head + "      - motion: " + kWalk + "\n      - {motion: " + kStand +
                   ", name: go, from: stand, to: walk}\n");
            }).find("transition 'go' names 'stand', which is not"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] {
              Read(head + "      - {motion: " + kWalk + ", from: stand}\n");
            }).find("a transition needs both"),
            std::string::npos);
  EXPECT_NE(
      ErrorOf([&] {
        Read(head + "      - motion: " + kWalk + "\n    command_interval: {min: 3, max: 1}\n");
      }).find("command_interval.max: must be at least"),
      std::string::npos);
  EXPECT_NE(ErrorOf([&] {
              Read(head + "      - {motion: " + kWalk + ", mirorr: true}\n");
            }).find("mirror"),
            std::string::npos);
}

TEST(SteeringConfigTest, WeightsSayHowOftenTrainingDrawsACommand) {
  const std::string head = "environment:\n  steering:\n    motions:\n";
  const EnvConfig c =
      Read(head + "      - {motion: " + kStand + ", weight: 2.5}\n      - motion: " + kWalk + "\n");
  EXPECT_DOUBLE_EQ(c.steering.motions[0].weight, 2.5);
  EXPECT_DOUBLE_EQ(c.steering.motions[1].weight, 1.0);
  EXPECT_NE(ErrorOf([&] {
              Read(head + "      - {motion: " + kWalk + ", weight: 0}\n");
            }).find("steering.motions[0].weight: must be a positive number"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] {
              Read(head + "      - motion: " + kStand + "\n      - motion: " + kWalk +
                   "\n      - {motion: " + kWalk +
                   ", name: go, from: stand, to: walk, weight: 2}\n");
            }).find("steering.motions[2].weight: a transition is never drawn"),
            std::string::npos);
}

TEST(SteeringConfigTest, CatchStepsAreOffUnlessAskedFor) {
  const std::string head = "environment:\n  steering:\n    motions:\n      - motion: " + kStand +
                           "\n      - motion: " + kWalk + "\n";
  EXPECT_EQ(Read(head).steering.catch_above, 0.0);
  const EnvConfig c = Read(head + "    catch_steps: {above: 0.6, seconds: 0.4}\n");
  EXPECT_DOUBLE_EQ(c.steering.catch_above, 0.6);
  EXPECT_DOUBLE_EQ(c.steering.catch_seconds, 0.4);
  const EnvConfig defaults = Read(head + "    catch_steps: {}\n");
  EXPECT_DOUBLE_EQ(defaults.steering.catch_above, 0.5);
  EXPECT_DOUBLE_EQ(defaults.steering.catch_seconds, 0.7);
  EXPECT_NE(ErrorOf([&] {
              Read(head + "    catch_steps: {above: 0}\n");
            }).find("catch_steps.above: must be a positive number"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] { Read(head + "    catch_steps: {second: 1}\n"); }).find("second"),
            std::string::npos);
}

class SteeringEnvTest : public ::testing::Test {
 protected:
  SteeringEnvTest() {
    config_.character = kAssets + "/character/humanoid.xml";
    config_.action_mode = ActionMode::kOffset;
    config_.substeps = 10;
    for (const std::string& m : {kStand, kWalk}) {
      MotionSetItem item;
      item.motion = m;
      item.name = m == kStand ? "stand" : "walk";
      config_.steering.motions.push_back(item);
    }
    config_.motion = kStand;
    character_ = character::Character::Load(config_.character, config_.physics_dt());
  }
  std::unique_ptr<ImitationEnv> Make(uint64_t seed = 1) {
    return std::make_unique<ImitationEnv>(character_, LoadMotionSet(config_, *character_), config_,
                                          seed);
  }
  EnvConfig config_;
  std::shared_ptr<const character::Character> character_;
};

TEST_F(SteeringEnvTest, ObservationCarriesTheCommand) {
  auto env = Make();
  const EnvSpec& spec = env->spec();
  const int base = ObservationSize(*character_);
  ASSERT_EQ(spec.observation_size, base + 5 + 2);
  ASSERT_EQ(spec.observation_names.size(), static_cast<size_t>(spec.observation_size));
  EXPECT_EQ(spec.observation_names[base], "command.forward");
  EXPECT_EQ(spec.observation_names[base + 4], "command.heading_error.cos");
  EXPECT_EQ(spec.observation_names[base + 6], "reference.walk");
  EXPECT_DOUBLE_EQ(spec.max_reward_per_step, 1.0 + 0.5);

  std::vector<float> obs(spec.observation_size);
  Steering(*env).SetCommand(*env, 1);
  env->Reset(obs.data());
  EXPECT_EQ(Steering(*env).command_entry(), 1);
  EXPECT_EQ(env->reference_entry(), 1);
  // The episode starts facing the desired heading.
  EXPECT_NEAR(obs[base], 0.9, 1e-6);
  EXPECT_NEAR(obs[base + 1], 0.0, 1e-6);
  EXPECT_EQ(obs[base + 2], 0.0f);
  EXPECT_NEAR(obs[base + 3], 0.0, 1e-6);
  EXPECT_NEAR(obs[base + 4], 1.0, 1e-6);
  EXPECT_EQ(obs[base + 5], 0.0f);
  EXPECT_EQ(obs[base + 6], 1.0f);
}

// The task term from the errors the environment reports, and the travel velocity from centre of
// mass positions recorded here, step by step.
TEST_F(SteeringEnvTest, TaskRewardTracksTheAveragedTravelVelocityAndHeading) {
  auto env = Make();
  std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size, 0.0f);
  Steering(*env).SetCommand(*env, 1);
  env->Reset(obs.data());
  const mjModel* m = character_->model();
  auto com = [&] {
    character::Vec3 c = {0, 0, 0};
    for (int b : character_->bodies()) {
      for (int k = 0; k < 3; ++k) c[k] += m->body_mass[b] * env->data().xipos[3 * b + k];
    }
    for (double& x : c) x /= character_->total_mass();
    return c;
  };
  const int window = 15;  // 0.5 s at 30 Hz
  std::vector<character::Vec3> history = {com()};
  for (int step = 0; step < 20; ++step) {
    StepResult r = env->Step(action.data(), obs.data());
    ASSERT_FALSE(r.terminated) << step;
    history.push_back(com());
    if (step + 1 < window) continue;
    const character::Vec3& now = history.back();
    const character::Vec3& then = history[history.size() - 1 - window];
    const character::Vec3 v = Steering(*env).TravelVelocity();
    EXPECT_NEAR(v[0], (now[0] - then[0]) / 0.5, 1e-9);
    EXPECT_NEAR(v[1], (now[1] - then[1]) / 0.5, 1e-9);
    const double h = Steering(*env).desired_heading();
    const double ex = v[0] - 0.9 * std::cos(h), ey = v[1] - 0.9 * std::sin(h);
    const double speed_error = std::hypot(ex, ey);
    EXPECT_NEAR(Steering(*env).SpeedError(), speed_error, 1e-12);
    const double heading_error = std::remainder(env->heading() - h, 2 * M_PI);
    EXPECT_NEAR(r.terms.task,
                0.3 * std::exp(-4.0 * speed_error * speed_error) +
                    0.2 * std::exp(-2.0 * heading_error * heading_error),
                1e-12);
    EXPECT_NEAR(r.reward, r.terms.total, 0);
    EXPECT_NEAR(r.terms.total - r.terms.task,
                0.5 * r.terms.rotation + 0.05 * r.terms.velocity + 0.15 * r.terms.end_effector +
                    0.1 * r.terms.com + 0.2 * r.terms.root,
                1e-12);
  }
  const std::vector<std::string>& figures = env->spec().figure_names;
  const auto speed = std::find(figures.begin(), figures.end(), "speed_error") - figures.begin();
  ASSERT_LT(speed, static_cast<long>(figures.size()));
  EXPECT_GT(env->episode().figures[speed], 0);
}

TEST_F(SteeringEnvTest, DesiredHeadingIntegratesTheTurnRate) {
  config_.steering.motions[1].command_from_clip = false;
  config_.steering.motions[1].command = {0.5, 0, 0.6};
  auto env = Make();
  std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size, 0.0f);
  Steering(*env).SetCommand(*env, 1);
  env->Reset(obs.data());
  const double start = Steering(*env).desired_heading();
  for (int step = 0; step < 10; ++step) env->Step(action.data(), obs.data());
  EXPECT_NEAR(std::remainder(Steering(*env).desired_heading() - start, 2 * M_PI), 10 * 0.6 / 30,
              1e-12);
  // The command seen from the character: (0.5, 0) turned by the heading error.
  const double e = std::remainder(Steering(*env).desired_heading() - env->heading(), 2 * M_PI);
  const int base = ObservationSize(*character_);
  EXPECT_NEAR(obs[base], 0.5 * std::cos(e), 1e-6);
  EXPECT_NEAR(obs[base + 1], 0.5 * std::sin(e), 1e-6);
  EXPECT_NEAR(obs[base + 2], 0.6, 1e-6);
  EXPECT_NEAR(obs[base + 3], std::sin(e), 1e-6);
}

TEST_F(SteeringEnvTest, TrainingSwitchesCommandsAtRandomTimesAndTheReferenceFollows) {
  config_.steering.command_interval_min = 0.5;
  config_.steering.command_interval_max = 1.0;
  config_.max_episode_steps = 100000;
  auto env = Make(7);
  std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size, 0.0f);
  env->Reset(obs.data());
  int switches = 0, previous = Steering(*env).command_entry();
  for (int step = 0; step < 300; ++step) {
    // Hold the character in the reference state so that it never falls.
    std::vector<double> qpos(character_->model()->nq), qvel(character_->model()->nv);
    env->ReferenceState(env->time(), qpos.data(), qvel.data());
    env->SetState(qpos.data(), qvel.data());
    StepResult r = env->Step(action.data(), obs.data());
    ASSERT_FALSE(r.terminated) << step;
    if (Steering(*env).command_entry() != previous) {
      ++switches;
      previous = Steering(*env).command_entry();
      EXPECT_EQ(env->reference_entry(), Steering(*env).command_entry());
      // The observation's one-hot names the clip now imitated (phase matching itself is checked
      // in PhaseMatchingPicksTheClosestKeyFrame).
      const int base = ObservationSize(*character_);
      EXPECT_EQ(obs[base + 5 + env->reference_entry()], 1.0f);
    }
  }
  // 10 s at one change per 0.5-1 s; each change picks stand or walk at random.
  EXPECT_GE(switches, 4);
  EXPECT_LE(switches, 20);
}

TEST_F(SteeringEnvTest, EpisodesDrawTheirCommandInProportionToTheWeights) {
  auto share_standing = [&](double stand_weight) {
    config_.steering.motions[0].weight = stand_weight;
    auto env = Make(3);
    std::vector<float> obs(env->spec().observation_size);
    int standing = 0;
    const int episodes = 2000;
    for (int i = 0; i < episodes; ++i) {
      env->Reset(obs.data());
      standing += Steering(*env).command_entry() == 0;
    }
    return static_cast<double>(standing) / episodes;
  };
  // Binomial standard deviations over 2000 draws: 0.011 and 0.009.
  EXPECT_NEAR(share_standing(1.0), 0.5, 0.04);
  EXPECT_NEAR(share_standing(4.0), 0.8, 0.04);
}

TEST_F(SteeringEnvTest, PhaseMatchingPicksTheClosestKeyFrame) {
  auto env = Make();
  std::vector<float> obs(env->spec().observation_size);
  Steering(*env).SetCommand(*env, 1);
  env->ResetAtPhase(0.37, obs.data());
  const double time = env->time();
  // From the walk to stand and back: the walk re-enters at the key frame nearest the pose the
  // character holds (its own 0.37 phase pose, unchanged since no step ran).
  Steering(*env).SetCommand(*env, 0);
  EXPECT_EQ(env->reference_entry(), 0);
  Steering(*env).SetCommand(*env, 1);
  const character::MotionClip& walk = env->clip();
  EXPECT_NEAR(env->time(),
              walk.frame_time(static_cast<int>(std::lround(time / walk.frame_duration(0)))), 1e-9);
  // The reference is placed on the character, facing the desired heading.
  std::vector<double> qpos(character_->model()->nq), qvel(character_->model()->nv);
  env->ReferenceState(env->time(), qpos.data(), qvel.data());
  EXPECT_NEAR(qpos[0], env->data().qpos[0], 1e-9);
  EXPECT_NEAR(qpos[1], env->data().qpos[1], 1e-9);
}

// Told to stand, a pelvis carried faster than `above` switches the reference to the set's clip
// whose travel is nearest (here the walk, ahead), for `seconds`, then back to the stand; a push
// toward where no clip travels, or one while walking, changes nothing.
TEST_F(SteeringEnvTest, APushWhileStandingIsCaughtWithAStepOfTheNearestClip) {
  config_.steering.catch_above = 0.5;
  config_.steering.catch_seconds = 0.5;
  auto env = Make();
  const int base = ObservationSize(*character_);
  std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size, 0.0f);
  std::vector<double> qpos(character_->model()->nq), qvel(character_->model()->nv);
  // One step from the reference's state with the pelvis moving at `speed` along the heading.
  auto step = [&](double speed) {
    env->ReferenceState(env->time(), qpos.data(), qvel.data());
    const double h = Steering(*env).desired_heading();
    qvel[0] = speed * std::cos(h);
    qvel[1] = speed * std::sin(h);
    env->SetState(qpos.data(), qvel.data());
    env->Step(action.data(), obs.data());
  };
  for (const double push : {1.5, -1.5}) {
    SCOPED_TRACE(push);
    Steering(*env).SetCommand(*env, 0);
    env->ResetAtPhase(0.0, obs.data());
    for (int i = 0; i < 5; ++i) step(0.0);
    EXPECT_EQ(env->reference_entry(), 0);
    step(push);
    if (push < 0) {  // backward: the stand is nearer than the walk
      EXPECT_EQ(env->reference_entry(), 0);
      EXPECT_EQ(Steering(*env).catching(), -1);
      continue;
    }
    EXPECT_EQ(env->reference_entry(), 1);
    EXPECT_EQ(Steering(*env).catching(), 1);
    // Still told to stand: the command seen and rewarded is the stand's, the clip the walk.
    EXPECT_NEAR(obs[base], Steering(*env).command().forward, 1e-6);
    EXPECT_EQ(obs[base + 5], 0.0f);
    EXPECT_EQ(obs[base + 6], 1.0f);
    int steps = 0;
    while (env->reference_entry() == 1 && steps < 100) {
      step(0.0);
      ++steps;
    }
    EXPECT_EQ(steps, 15);  // 0.5 s at 30 Hz after the step that began it
    EXPECT_EQ(env->reference_entry(), 0);
    EXPECT_EQ(Steering(*env).catching(), -1);
  }
  // Walking, a push is the walk's to absorb.
  Steering(*env).SetCommand(*env, 1);
  step(2.0);
  EXPECT_EQ(env->reference_entry(), 1);
  EXPECT_EQ(Steering(*env).catching(), -1);
}

// A command given during a catch step waits for its end, then leads as usual.
TEST_F(SteeringEnvTest, ACommandGivenDuringACatchStepWaitsForItsEnd) {
  config_.steering.catch_above = 0.5;
  config_.steering.catch_seconds = 0.3;
  auto env = Make();
  std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size, 0.0f);
  std::vector<double> qpos(character_->model()->nq), qvel(character_->model()->nv);
  Steering(*env).SetCommand(*env, 0);
  env->ResetAtPhase(0.0, obs.data());
  env->ReferenceState(env->time(), qpos.data(), qvel.data());
  const double h = Steering(*env).desired_heading();
  qvel[0] = 1.5 * std::cos(h);
  qvel[1] = 1.5 * std::sin(h);
  env->SetState(qpos.data(), qvel.data());
  env->Step(action.data(), obs.data());
  ASSERT_EQ(Steering(*env).catching(), 1);
  Steering(*env).SetCommand(*env, 0);  // the same command: nothing to wait for
  Steering(*env).SetCommand(*env, 1);
  Steering(*env).SetCommand(*env, 0);  // and back: the stand it is told now waits too
  EXPECT_EQ(env->reference_entry(), 1);
  for (int i = 0; i < 9; ++i) env->Step(action.data(), obs.data());
  EXPECT_EQ(Steering(*env).catching(), -1);
  EXPECT_EQ(env->reference_entry(), 0);
}

TEST_F(SteeringEnvTest, TransitionsPlayThenHandOver) {
  auto character = character_;
  std::vector<MotionSetEntry> entries;
  auto stand = std::make_shared<const character::MotionClip>(character::LoadMotion(kStand));
  auto walk = std::make_shared<const character::MotionClip>(character::LoadMotion(kWalk));
  entries.push_back({"stand", stand, MeasureCommand(*stand)});
  entries.push_back({"walk", walk, MeasureCommand(*walk)});
  entries.push_back({"start", StandTransition(), MeasureCommand(*walk), 0, 1});
  MotionSetItem start;
  start.motion = kStand;
  start.name = "start";
  start.from = "stand";
  start.to = "walk";
  config_.steering.motions.push_back(start);
  auto motions = std::make_shared<const MotionSet>(entries);
  ImitationEnv env(character_, motions, config_, 3);
  std::vector<float> obs(env.spec().observation_size), action(env.spec().action_size, 0.0f);
  Steering(env).SetCommand(env, 0);
  env.ResetAtPhase(0.0, obs.data());
  Steering(env).SetCommand(env, 1);
  EXPECT_EQ(Steering(env).command_entry(), 1);
  EXPECT_EQ(env.reference_entry(), 2);  // the transition plays first
  EXPECT_NEAR(env.time(), 0.0, 1e-12);  // its first half holds stand's pose: entered at the start
  int steps = 0;
  while (env.reference_entry() == 2 && steps < 100) {
    std::vector<double> qpos(character_->model()->nq), qvel(character_->model()->nv);
    env.ReferenceState(env.time(), qpos.data(), qvel.data());
    env.SetState(qpos.data(), qvel.data());
    env.Step(action.data(), obs.data());
    ++steps;
  }
  // 29 frame intervals of 1/30 s: it hands over to the walk once its time passes the end.
  EXPECT_EQ(steps, 29);
  EXPECT_EQ(env.reference_entry(), 1);
  // Back to stand: no transition listed from walk, so straight to the clip.
  Steering(env).SetCommand(env, 0);
  EXPECT_EQ(env.reference_entry(), 0);
}

TEST_F(SteeringEnvTest, RolloutsAreBitIdenticalForASeed) {
  config_.steering.command_interval_min = 0.3;
  config_.steering.command_interval_max = 0.6;
  auto run = [&](uint64_t seed) {
    auto env = Make(seed);
    std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size);
    std::vector<float> trace;
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(-0.3f, 0.3f);
    env->Reset(obs.data());
    for (int step = 0; step < 200; ++step) {
      for (float& a : action) a = u(rng);
      StepResult r = env->Step(action.data(), obs.data());
      trace.insert(trace.end(), obs.begin(), obs.end());
      trace.push_back(static_cast<float>(r.reward));
      trace.push_back(static_cast<float>(Steering(*env).command_entry()));
      if (r.terminated || r.truncated) env->Reset(obs.data());
    }
    return trace;
  };
  auto a = run(11), b = run(11), c = run(12);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(float)));
  EXPECT_NE(a, c);
}

// The learner learns the sizes and the figures without building an environment.
TEST_F(SteeringEnvTest, TheSpecComesFromTheConfigAlone) {
  auto env = Make();
  const EnvSpec spec = MakeEnvSpec(config_, *character_);
  EXPECT_EQ(spec.observation_size, env->spec().observation_size);
  EXPECT_EQ(spec.observation_names, env->spec().observation_names);
  EXPECT_EQ(spec.action_names, env->spec().action_names);
  EXPECT_EQ(spec.max_reward_per_step, env->spec().max_reward_per_step);
  EXPECT_EQ(spec.figure_names,
            (std::vector<std::string>{"rotation", "velocity", "end_effector", "com", "root", "task",
                                      "speed_error", "heading_error"}));
  EXPECT_EQ(spec.figure_names, env->spec().figure_names);
  EXPECT_EQ(spec.reward_terms, 6);
  EXPECT_EQ(spec.task, "steering");
  EnvConfig plain = config_;
  plain.steering = SteeringConfig();
  const EnvSpec walk = MakeEnvSpec(plain, *character_);
  EXPECT_EQ(walk.observation_size, ObservationSize(*character_));
  EXPECT_EQ(walk.figure_names.size(), 5u);
  EXPECT_EQ(walk.task, "");
}

TEST_F(SteeringEnvTest, CommandsAreRefusedWithoutSteeringAndOutsideTheSet) {
  auto env = Make();
  EXPECT_THROW(Steering(*env).SetCommand(*env, 2), std::invalid_argument);
  EXPECT_THROW(Steering(*env).SetCommand(*env, -1), std::invalid_argument);
  EnvConfig plain;
  plain.character = config_.character;
  plain.motion = kWalk;
  plain.substeps = 10;
  ImitationEnv single(character_,
                      std::make_shared<const character::MotionClip>(character::LoadMotion(kWalk)),
                      plain, 1);
  EXPECT_EQ(single.task().name(), "");
  EXPECT_EQ(single.spec().observation_size, ObservationSize(*character_));
  EXPECT_THROW(Steering(single), std::logic_error);
}

}  // namespace
}  // namespace ragdoll::sim
