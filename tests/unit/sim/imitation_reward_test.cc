#include "sim/imitation_reward.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace ragdoll::sim {
namespace {

// Four joints weighing 1, 2, 3 and 4 (normalised: 0.1, 0.2, 0.3, 0.4); six hinges, three of
// them on joint 1.
const std::vector<double> kJointWeights = {1, 2, 3, 4};
const std::vector<int> kHingeJoint = {0, 1, 1, 1, 2, 3};

PoseFeatures Reference() {
  PoseFeatures f;
  f.joint_rotations = {character::AxisAngle({1, 0, 0}, 0.2), character::AxisAngle({0, 1, 0}, -0.4),
                       character::AxisAngle({0, 0.6, 0.8}, 1.0), character::kIdentityQuat};
  f.joint_velocities = {0.5, -1, 2, 0, 1.5, -0.3};
  f.end_effectors = {{0.2, -0.3, -0.9}, {0.2, 0.3, -0.9}, {0, -0.4, 0.1}, {0, 0.4, 0.1}};
  f.com = {0.1, 0.02, 0.85};
  f.root_position = {0.1, 0, 0.9};
  f.root_rotation = character::AxisAngle({0, 0, 1}, 0.7);
  f.root_linear_velocity = {1.2, 0.1, 0};
  f.root_angular_velocity = {0, 0.2, 0.5};
  return f;
}

TEST(ImitationReward, IdenticalFeaturesScoreTheMaximum) {
  RewardConfig config;
  PoseFeatures ref = Reference();
  RewardErrors e = ImitationErrors(config, kJointWeights, kHingeJoint, ref, ref);
  EXPECT_NEAR(e.rotation, 0, 1e-20);
  EXPECT_EQ(e.velocity, 0);
  EXPECT_EQ(e.end_effector, 0);
  EXPECT_EQ(e.com, 0);
  EXPECT_NEAR(e.root, 0, 1e-20);
  RewardTerms t = ImitationReward(config, e);
  EXPECT_EQ(t.rotation, 1);
  EXPECT_EQ(t.velocity, 1);
  EXPECT_EQ(t.end_effector, 1);
  EXPECT_EQ(t.com, 1);
  EXPECT_EQ(t.root, 1);
  // The default weights 0.5 + 0.05 + 0.15 + 0.1 + 0.2 sum to 1.
  EXPECT_DOUBLE_EQ(t.total, config.MaxReward());
  EXPECT_NEAR(t.total, 1.0, 1e-15);

  RewardConfig heavy;
  heavy.rotation_weight = 1, heavy.velocity_weight = 2, heavy.end_effector_weight = 3;
  heavy.com_weight = 4, heavy.root_weight = 5;
  EXPECT_EQ(ImitationReward(heavy, e).total, 15);
  EXPECT_EQ(heavy.MaxReward(), 15);
}

TEST(ImitationReward, QAndMinusQAreTheSamePose) {
  RewardConfig config;
  PoseFeatures ref = Reference();
  PoseFeatures sim = ref;
  for (character::Quat& q : sim.joint_rotations) q = {-q[0], -q[1], -q[2], -q[3]};
  sim.root_rotation = {-ref.root_rotation[0], -ref.root_rotation[1], -ref.root_rotation[2],
                       -ref.root_rotation[3]};
  RewardErrors e = ImitationErrors(config, kJointWeights, kHingeJoint, sim, ref);
  EXPECT_NEAR(e.rotation, 0, 1e-20);
  EXPECT_NEAR(e.root, 0, 1e-20);
}

TEST(ImitationReward, OneJointRotatedBy0Point3Rad) {
  RewardConfig config;
  PoseFeatures ref = Reference();
  PoseFeatures sim = ref;
  // Joint 2 (weight 3 of 10) turned a further 0.3 rad about an oblique axis.
  sim.joint_rotations[2] =
      character::Multiply(ref.joint_rotations[2], character::AxisAngle({0.6, 0, 0.8}, 0.3));
  RewardErrors e = ImitationErrors(config, kJointWeights, kHingeJoint, sim, ref);
  // 0.3 * 0.3^2 = 0.027
  EXPECT_NEAR(e.rotation, 0.027, 1e-12);
  RewardTerms t = ImitationReward(config, e);
  // exp(-2 * 0.027) = exp(-0.054) = 0.9474321
  EXPECT_NEAR(t.rotation, std::exp(-0.054), 1e-12);
  EXPECT_NEAR(t.rotation, 0.9474321, 1e-7);
  EXPECT_EQ(t.velocity, 1);
  EXPECT_EQ(t.end_effector, 1);
  EXPECT_EQ(t.com, 1);
  EXPECT_EQ(t.root, 1);
  // 0.5 * 0.9474321 + (0.05 + 0.15 + 0.1 + 0.2) = 0.97371605
  EXPECT_NEAR(t.total, 0.5 * std::exp(-0.054) + 0.5, 1e-12);
}

TEST(ImitationReward, JointVelocityDifferencesWeighByTheirJoint) {
  RewardConfig config;
  PoseFeatures ref = Reference();
  PoseFeatures sim = ref;
  // Hinge 3 belongs to joint 1 (weight 0.2): 2 rad/s off gives 0.2 * 2^2 = 0.8.
  sim.joint_velocities[3] += 2;
  RewardErrors e = ImitationErrors(config, kJointWeights, kHingeJoint, sim, ref);
  EXPECT_NEAR(e.velocity, 0.8, 1e-12);
  EXPECT_NEAR(e.rotation, 0, 1e-20);
  // exp(-0.1 * 0.8) = exp(-0.08) = 0.9231163
  RewardTerms t = ImitationReward(config, e);
  EXPECT_NEAR(t.velocity, 0.9231163, 1e-7);
  EXPECT_NEAR(t.total, 0.05 * std::exp(-0.08) + 0.95, 1e-12);

  // Hinge 0 (joint 0, weight 0.1) 1 rad/s slow and hinge 5 (joint 3, weight 0.4) 0.5 rad/s fast:
  // 0.1 * 1 + 0.4 * 0.25 = 0.2.
  sim = ref;
  sim.joint_velocities[0] -= 1;
  sim.joint_velocities[5] += 0.5;
  EXPECT_NEAR(ImitationErrors(config, kJointWeights, kHingeJoint, sim, ref).velocity, 0.2, 1e-12);
}

TEST(ImitationReward, EndEffectorErrorIsTheMeanSquaredDistance) {
  RewardConfig config;
  PoseFeatures ref = Reference();
  PoseFeatures sim = ref;
  // One of four end effectors 0.1 m off: 0.1^2 / 4 = 0.0025.
  sim.end_effectors[2][1] += 0.1;
  RewardErrors e = ImitationErrors(config, kJointWeights, kHingeJoint, sim, ref);
  EXPECT_NEAR(e.end_effector, 0.0025, 1e-12);
  // exp(-10 * 0.0025) = exp(-0.025) = 0.9753099
  RewardTerms t = ImitationReward(config, e);
  EXPECT_NEAR(t.end_effector, 0.9753099, 1e-7);
  EXPECT_NEAR(t.total, 0.15 * std::exp(-0.025) + 0.85, 1e-12);
}

TEST(ImitationReward, CentreOfMassOffset) {
  RewardConfig config;
  PoseFeatures ref = Reference();
  PoseFeatures sim = ref;
  // (0.03, -0.04, 0) m off: 0.0009 + 0.0016 = 0.0025 m^2.
  sim.com[0] += 0.03;
  sim.com[1] -= 0.04;
  RewardErrors e = ImitationErrors(config, kJointWeights, kHingeJoint, sim, ref);
  EXPECT_NEAR(e.com, 0.0025, 1e-12);
  RewardTerms t = ImitationReward(config, e);
  EXPECT_NEAR(t.com, std::exp(-0.025), 1e-12);
  EXPECT_NEAR(t.total, 0.1 * std::exp(-0.025) + 0.9, 1e-12);
}

TEST(ImitationReward, RootErrorMixesPositionRotationAndVelocities) {
  RewardConfig config;
  PoseFeatures ref = Reference();
  PoseFeatures sim = ref;
  sim.root_position[2] += 0.1;  // 0.01 m^2
  sim.root_rotation =
      character::Multiply(ref.root_rotation, character::AxisAngle({0, 0, 1}, 0.2));  // 0.04 rad^2
  sim.root_linear_velocity[0] += 1;                                                  // 1 (m/s)^2
  sim.root_angular_velocity[1] += 2;                                                 // 4 (rad/s)^2
  RewardErrors e = ImitationErrors(config, kJointWeights, kHingeJoint, sim, ref);
  // 0.01 + 0.1 * 0.04 + 0.01 * 1 + 0.001 * 4 = 0.01 + 0.004 + 0.01 + 0.004 = 0.028
  EXPECT_NEAR(e.root, 0.028, 1e-12);
  RewardTerms t = ImitationReward(config, e);
  // exp(-5 * 0.028) = exp(-0.14) = 0.8693582
  EXPECT_NEAR(t.root, 0.8693582, 1e-7);
  EXPECT_NEAR(t.total, 0.2 * std::exp(-0.14) + 0.8, 1e-12);

  // The factors are the config's: doubling the rotation factor adds another 0.004.
  config.root_rotation_factor = 0.2;
  EXPECT_NEAR(ImitationErrors(config, kJointWeights, kHingeJoint, sim, ref).root, 0.032, 1e-12);
}

TEST(ImitationReward, AllTermsTogether) {
  RewardConfig config;
  PoseFeatures ref = Reference();
  PoseFeatures sim = ref;
  sim.joint_rotations[2] =
      character::Multiply(ref.joint_rotations[2], character::AxisAngle({0.6, 0, 0.8}, 0.3));
  sim.joint_velocities[3] += 2;
  sim.end_effectors[2][1] += 0.1;
  sim.com[0] += 0.03;
  sim.com[1] -= 0.04;
  sim.root_position[2] += 0.1;
  sim.root_rotation = character::Multiply(ref.root_rotation, character::AxisAngle({0, 0, 1}, 0.2));
  sim.root_linear_velocity[0] += 1;
  sim.root_angular_velocity[1] += 2;
  RewardTerms t =
      ImitationReward(config, ImitationErrors(config, kJointWeights, kHingeJoint, sim, ref));
  // 0.5 * 0.9474321 + 0.05 * 0.9231163 + 0.15 * 0.9753099 + 0.1 * 0.9753099 + 0.2 * 0.8693582
  // = 0.4737161 + 0.0461558 + 0.1462965 + 0.0975310 + 0.1738716 = 0.9375710
  EXPECT_NEAR(t.total, 0.9375710, 1e-7);
}

TEST(ImitationReward, ScalesComeFromTheConfig) {
  RewardConfig config;
  config.rotation_scale = 4;
  config.com_scale = 0;  // a zero scale makes the term always 1
  RewardErrors e;
  e.rotation = 0.1;
  e.com = 5;
  RewardTerms t = ImitationReward(config, e);
  EXPECT_NEAR(t.rotation, std::exp(-0.4), 1e-15);
  EXPECT_EQ(t.com, 1);
}

TEST(ImitationReward, JointsWithoutWeightAreIgnored) {
  RewardConfig config;
  PoseFeatures ref = Reference();
  PoseFeatures sim = ref;
  sim.joint_rotations[0] = character::AxisAngle({1, 0, 0}, 2.0);
  sim.joint_velocities[0] += 5;
  // Only joint 0 is off, and it weighs nothing; joints 1..3 weigh 1/3 each.
  std::vector<double> weights = {0, 1, 1, 1};
  RewardErrors e = ImitationErrors(config, weights, kHingeJoint, sim, ref);
  EXPECT_NEAR(e.rotation, 0, 1e-20);
  EXPECT_EQ(e.velocity, 0);
  // Joint 3 off by 0.6 rad: (1/3) * 0.36 = 0.12.
  sim.joint_rotations[3] = character::AxisAngle({0, 0, 1}, 0.6);
  EXPECT_NEAR(ImitationErrors(config, weights, kHingeJoint, sim, ref).rotation, 0.12, 1e-12);
}

}  // namespace
}  // namespace ragdoll::sim
