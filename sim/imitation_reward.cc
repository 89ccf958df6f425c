#include "sim/imitation_reward.h"

#include <cmath>

namespace ragdoll::sim {
namespace {

double SquaredDistance(const character::Vec3& a, const character::Vec3& b) {
  double s = 0;
  for (int k = 0; k < 3; ++k) s += (a[k] - b[k]) * (a[k] - b[k]);
  return s;
}

}  // namespace

RewardErrors ImitationErrors(const RewardConfig& config, const std::vector<double>& joint_weights,
                             const std::vector<int>& hinge_joint, const PoseFeatures& sim,
                             const PoseFeatures& ref) {
  RewardErrors e;
  double weight_sum = 0;
  for (double w : joint_weights) weight_sum += w;
  double normaliser = weight_sum > 0 ? 1 / weight_sum : 0;

  for (size_t j = 0; j < sim.joint_rotations.size(); ++j) {
    double angle = character::AngleBetween(sim.joint_rotations[j], ref.joint_rotations[j]);
    e.rotation += joint_weights[j] * normaliser * angle * angle;
  }
  for (size_t i = 0; i < sim.joint_velocities.size(); ++i) {
    double d = sim.joint_velocities[i] - ref.joint_velocities[i];
    e.velocity += joint_weights[hinge_joint[i]] * normaliser * d * d;
  }
  for (size_t k = 0; k < sim.end_effectors.size(); ++k) {
    e.end_effector += SquaredDistance(sim.end_effectors[k], ref.end_effectors[k]);
  }
  if (!sim.end_effectors.empty()) e.end_effector /= static_cast<double>(sim.end_effectors.size());
  e.com = SquaredDistance(sim.com, ref.com);
  double root_angle = character::AngleBetween(sim.root_rotation, ref.root_rotation);
  e.root = SquaredDistance(sim.root_position, ref.root_position) +
           config.root_rotation_factor * root_angle * root_angle +
           config.root_linear_velocity_factor *
               SquaredDistance(sim.root_linear_velocity, ref.root_linear_velocity) +
           config.root_angular_velocity_factor *
               SquaredDistance(sim.root_angular_velocity, ref.root_angular_velocity);
  return e;
}

RewardTerms ImitationReward(const RewardConfig& config, const RewardErrors& errors) {
  RewardTerms t;
  t.rotation = std::exp(-config.rotation_scale * errors.rotation);
  t.velocity = std::exp(-config.velocity_scale * errors.velocity);
  t.end_effector = std::exp(-config.end_effector_scale * errors.end_effector);
  t.com = std::exp(-config.com_scale * errors.com);
  t.root = std::exp(-config.root_scale * errors.root);
  t.total = config.rotation_weight * t.rotation + config.velocity_weight * t.velocity +
            config.end_effector_weight * t.end_effector + config.com_weight * t.com +
            config.root_weight * t.root;
  return t;
}

}  // namespace ragdoll::sim
