#include "character/skeleton.h"

namespace ragdoll::character {

const std::vector<SkeletonJoint>& Humanoid3dJoints() {
  static const std::vector<SkeletonJoint> joints = {
      {"chest", JointType::kSpherical},         {"neck", JointType::kSpherical},
      {"right_hip", JointType::kSpherical},     {"right_knee", JointType::kRevolute},
      {"right_ankle", JointType::kSpherical},   {"right_shoulder", JointType::kSpherical},
      {"right_elbow", JointType::kRevolute},    {"left_hip", JointType::kSpherical},
      {"left_knee", JointType::kRevolute},      {"left_ankle", JointType::kSpherical},
      {"left_shoulder", JointType::kSpherical}, {"left_elbow", JointType::kRevolute},
  };
  return joints;
}

int FindJoint(const std::string& name) {
  const auto& joints = Humanoid3dJoints();
  for (size_t i = 0; i < joints.size(); ++i) {
    if (joints[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

}  // namespace ragdoll::character
