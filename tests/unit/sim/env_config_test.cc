#include "sim/env_config.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "common/config_section.h"

namespace ragdoll::sim {
namespace {

using ::testing::HasSubstr;

const std::string kDefaultCharacter = "assets/character/humanoid.xml";

EnvConfig Read(const std::string& yaml) {
  return ReadEnvConfig(ConfigSection::FromString(yaml, "env.yaml"), kDefaultCharacter);
}

// The message of the ConfigError that reading `yaml` throws, or "" (and a failure).
std::string ReadError(const std::string& yaml) {
  try {
    Read(yaml);
  } catch (const ConfigError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected a ConfigError for:\n" << yaml;
  return "";
}

TEST(EnvConfig, DefaultsNeedOnlyAMotion) {
  EnvConfig c = Read("motion: motions/walk.json\n");
  EXPECT_EQ(c.motion, "motions/walk.json");
  EXPECT_EQ(c.character, kDefaultCharacter);
  EXPECT_EQ(c.control_frequency, 30);
  EXPECT_EQ(c.substeps, 20);
  EXPECT_EQ(c.max_episode_steps, 300);
  EXPECT_EQ(c.action_mode, ActionMode::kAbsolute);
  EXPECT_EQ(c.offset_scale, 0.5);
  EXPECT_TRUE(c.random_start);
  EXPECT_EQ(c.start_phase, 0);
  EXPECT_TRUE(c.contacts_from_clip);  // allowed_contacts: auto
  EXPECT_TRUE(c.allowed_contacts.empty());
  EXPECT_EQ(c.max_root_distance, 1.0);
  EXPECT_EQ(c.joint_weights.size(), 12u);
  EXPECT_EQ(c.joint_weights.at("chest"), 0.5);
  EXPECT_EQ(c.joint_weights.at("left_elbow"), 0.2);
  EXPECT_EQ(c.reward.rotation_weight, 0.5);
  EXPECT_EQ(c.reward.root_scale, 5.0);
  EXPECT_EQ(c.reward.root_angular_velocity_factor, 0.001);
  EXPECT_NEAR(c.reward.MaxReward(), 1.0, 1e-15);
  // 1 / 30 s per decision, 1 / (30 * 20) = 1 / 600 s per physics step.
  EXPECT_DOUBLE_EQ(c.control_dt(), 1.0 / 30);
  EXPECT_DOUBLE_EQ(c.physics_dt(), 1.0 / 600);
}

TEST(EnvConfig, ReadsEveryKey) {
  EnvConfig c = Read(
      "motion: walk.json\n"
      "character: other.xml\n"
      "control_frequency: 60\n"
      "substeps: 10\n"
      "max_episode_steps: 100\n"
      "action_mode: offset\n"
      "offset_scale: 0.25\n"
      "random_start: false\n"
      "start_phase: 0.5\n"
      "allowed_contacts: [right_ankle, left_ankle, right_wrist]\n"
      "max_root_distance: 0.5\n"
      "sync_reference: position\n"
      "joint_weights: {neck: 0, chest: 1.5}\n"
      "reward: {rotation_weight: 0.7, com_scale: 20, root_rotation_factor: 0.5}\n");
  EXPECT_EQ(c.character, "other.xml");
  EXPECT_EQ(c.control_frequency, 60);
  EXPECT_EQ(c.substeps, 10);
  EXPECT_EQ(c.max_episode_steps, 100);
  EXPECT_EQ(c.action_mode, ActionMode::kOffset);
  EXPECT_EQ(c.offset_scale, 0.25);
  EXPECT_FALSE(c.random_start);
  EXPECT_EQ(c.start_phase, 0.5);
  EXPECT_FALSE(c.contacts_from_clip);
  EXPECT_EQ(c.allowed_contacts,
            (std::vector<std::string>{"right_ankle", "left_ankle", "right_wrist"}));
  EXPECT_EQ(c.max_root_distance, 0.5);
  EXPECT_EQ(c.reference_sync, ReferenceSync::kPosition);
  EXPECT_EQ(c.joint_weights.at("neck"), 0);
  EXPECT_EQ(c.joint_weights.at("chest"), 1.5);
  EXPECT_EQ(c.joint_weights.at("right_hip"), 0.5);  // unchanged
  EXPECT_EQ(c.reward.rotation_weight, 0.7);
  EXPECT_EQ(c.reward.com_scale, 20);
  EXPECT_EQ(c.reward.root_rotation_factor, 0.5);
  EXPECT_EQ(c.reward.velocity_weight, 0.05);  // unchanged
  EXPECT_DOUBLE_EQ(c.physics_dt(), 1.0 / 600);
}

TEST(EnvConfig, BadValuesNameTheKey) {
  EXPECT_EQ(ReadError("motion: walk.json\nsubsteps: -2\n"),
            "env.yaml:2: substeps: must be at least 1");
  EXPECT_TRUE(Read("motion: walk.json\nallowed_contacts: auto\n").contacts_from_clip);
  EXPECT_THAT(ReadError("motion: walk.json\nallowed_contacts: feet\n"),
              HasSubstr("env.yaml:2: allowed_contacts: expected 'auto' (the bodies the clip puts "
                        "on the floor) or a list of bodies"));
  EXPECT_EQ(ReadError("motion: walk.json\nsync_reference: always\n"),
            "env.yaml:2: sync_reference: expected 'none', 'position' or 'position_and_heading', "
            "got 'always'");
  EXPECT_EQ(Read("motion: walk.json\n").reference_sync, ReferenceSync::kPositionAndHeading);
  EXPECT_EQ(ReadError("motion: walk.json\nsubsteps: 0\n"),
            "env.yaml:2: substeps: must be at least 1");
  EXPECT_EQ(ReadError("motion: walk.json\naction_mode: foo\n"),
            "env.yaml:2: action_mode: expected 'absolute' or 'offset', got 'foo'");
  EXPECT_EQ(ReadError("motion: walk.json\nstart_phase: 1.5\n"),
            "env.yaml:2: start_phase: must be in [0, 1)");
  EXPECT_THAT(ReadError("motion: walk.json\nstart_phase: -0.1\n"),
              HasSubstr("env.yaml:2: start_phase"));
  EXPECT_THAT(ReadError("motion: walk.json\ncontrol_frequency: -30\n"),
              HasSubstr("env.yaml:2: control_frequency: must be a positive number"));
  EXPECT_THAT(ReadError("motion: walk.json\nmax_episode_steps: 0\n"),
              HasSubstr("env.yaml:2: max_episode_steps: must be at least 1"));
  EXPECT_THAT(ReadError("motion: walk.json\nsubsteps: twenty\n"),
              HasSubstr("env.yaml:2: substeps: cannot read 'twenty'"));
  EXPECT_THAT(ReadError("motion: walk.json\nreward:\n  com_weight: -1\n"),
              HasSubstr("env.yaml:3: reward.com_weight: must be zero or more"));
  EXPECT_THAT(ReadError("motion: walk.json\njoint_weights:\n  neck: -0.3\n"),
              HasSubstr("env.yaml:3: joint_weights.neck: must be zero or more"));
  EXPECT_THAT(ReadError("motion: walk.json\nreward: {rotation_weight: 0, velocity_weight: 0, "
                        "end_effector_weight: 0, com_weight: 0, root_weight: 0}\n"),
              HasSubstr("reward.rotation_weight: at least one reward weight must be positive"));
}

TEST(EnvConfig, UnknownKeysGetAHint) {
  EXPECT_EQ(ReadError("motion: walk.json\nreward:\n  rotation_wieght: 0.7\n"),
            "env.yaml:3: unknown key 'reward.rotation_wieght'; did you mean 'rotation_weight'?");
  EXPECT_EQ(ReadError("motion: walk.json\njoint_weights:\n  left_knees: 0.3\n"),
            "env.yaml:3: unknown key 'joint_weights.left_knees'; did you mean 'left_knee'?");
  EXPECT_EQ(ReadError("motion: walk.json\nsubstep: 10\n"),
            "env.yaml:2: unknown key 'substep'; did you mean 'substeps'?");
}

TEST(EnvConfig, MotionIsRequired) {
  EXPECT_THAT(ReadError("substeps: 10\n"), HasSubstr("motion: required"));
  EXPECT_THAT(ReadError(""), HasSubstr("env.yaml:1: motion: required"));
}

}  // namespace
}  // namespace ragdoll::sim
