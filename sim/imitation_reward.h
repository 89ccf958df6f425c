// The DeepMimic imitation reward: a weighted sum of exp(-k * error^2) terms comparing the
// simulated character with the reference pose. Pure functions.
#pragma once

#include <vector>

#include "character/rotation.h"

namespace ragdoll::sim {

struct RewardConfig {
  // Weights w of each term; the largest possible reward per step is their sum.
  double rotation_weight = 0.5;
  double velocity_weight = 0.05;
  double end_effector_weight = 0.15;
  double com_weight = 0.1;
  double root_weight = 0.2;
  // Scales k of each term's exp(-k * error).
  double rotation_scale = 2.0;
  double velocity_scale = 0.1;
  double end_effector_scale = 10.0;
  double com_scale = 10.0;
  double root_scale = 5.0;
  // The root error mixes position (m^2) with rotation (rad^2), linear velocity ((m/s)^2) and
  // angular velocity ((rad/s)^2) using these factors, as DeepMimic does.
  double root_rotation_factor = 0.1;
  double root_linear_velocity_factor = 0.01;
  double root_angular_velocity_factor = 0.001;

  double MaxReward() const {
    return rotation_weight + velocity_weight + end_effector_weight + com_weight + root_weight;
  }
};

// What the reward compares, for the simulated character or the reference.
struct PoseFeatures {
  std::vector<character::Quat> joint_rotations;  // per skeleton joint, relative to its parent
  std::vector<double> joint_velocities;          // per actuated hinge, rad/s
  std::vector<character::Vec3> end_effectors;  // hands and feet relative to the root, world axes, m
  character::Vec3 com = {0, 0, 0};             // centre of mass, world, m
  character::Vec3 root_position = {0, 0, 0};
  character::Quat root_rotation = character::kIdentityQuat;
  character::Vec3 root_linear_velocity = {0, 0, 0};   // world, m/s
  character::Vec3 root_angular_velocity = {0, 0, 0};  // root frame, rad/s
};

// The imitation terms' names, as episode figures and in evaluations, in RewardTerms' order.
inline constexpr const char* kImitationTerms[] = {"rotation", "velocity", "end_effector", "com",
                                                  "root"};

// Each term in [0, 1] and their weighted sum.
struct RewardTerms {
  double rotation = 0;
  double velocity = 0;
  double end_effector = 0;
  double com = 0;
  double root = 0;
  // The steering task's part (velocity and heading tracking, weighted); 0 without steering.
  double task = 0;
  double total = 0;  // every weighted term, the task's included
};

// The squared errors inside each term.
struct RewardErrors {
  // sum_j w_j * angle(q_j, q^_j)^2, with the joint weights w normalised to sum to one
  double rotation = 0;
  // sum_j w_j * sum over j's hinges of (dq - dq^)^2
  double velocity = 0;
  // mean over end effectors of |p_e - p^_e|^2
  double end_effector = 0;
  // |c - c^|^2
  double com = 0;
  // |p - p^|^2 + f_r angle(q, q^)^2 + f_v |v - v^|^2 + f_w |w - w^|^2
  double root = 0;
};

// `joint_weights` has one entry per skeleton joint (normalised here); `hinge_joint[i]` is the
// skeleton joint that actuated hinge i belongs to.
RewardErrors ImitationErrors(const RewardConfig& config, const std::vector<double>& joint_weights,
                             const std::vector<int>& hinge_joint, const PoseFeatures& sim,
                             const PoseFeatures& ref);
RewardTerms ImitationReward(const RewardConfig& config, const RewardErrors& errors);

}  // namespace ragdoll::sim
