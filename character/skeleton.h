// The humanoid3d skeleton shared with DeepMimic: which joints a motion clip animates.
#pragma once

#include <string>
#include <vector>

namespace ragdoll::character {

enum class JointType { kSpherical, kRevolute };

struct SkeletonJoint {
  std::string name;
  JointType type;
};

// The animated joints of humanoid3d in DeepMimic's motion-file order (the root, whose position
// and rotation every clip carries, and the welded wrists are not listed): chest, neck, right_hip,
// right_knee, right_ankle, right_shoulder, right_elbow, left_hip, left_knee, left_ankle,
// left_shoulder, left_elbow.
const std::vector<SkeletonJoint>& Humanoid3dJoints();

// Index of the named joint in Humanoid3dJoints(), or -1.
int FindJoint(const std::string& name);

}  // namespace ragdoll::character
