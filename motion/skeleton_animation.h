// An animated skeleton as every reader hands it to the retargeter: joints in a hierarchy, where
// each joint is (world rotation and position) in the file's rest pose and at every frame. BVH
// files (motion/bvh.h) and the scene formats Assimp reads (FBX, glTF, COLLADA:
// motion/scene_import.h) both become one of these, so mapping and retargeting never depend
// on where the motion came from.
#pragma once

#include <string>
#include <vector>

#include "character/rotation.h"
#include "motion/bvh.h"

namespace ragdoll::motion {

struct AnimatedJoint {
  std::string name;  // as in the file; BVH end sites are "<parent>_end"
  int parent = -1;   // index into SkeletonAnimation::joints; -1 for the root
  bool end_site = false;
};

struct JointPose {
  character::Quat rotation = character::kIdentityQuat;  // world frame of the file
  character::Vec3 position = {0, 0, 0};                 // file units
};

struct SkeletonAnimation {
  std::string origin;                          // file name, for messages
  std::string format;                          // "BVH", "FBX", "glTF2", ...
  std::vector<AnimatedJoint> joints;           // parents before children
  std::vector<JointPose> rest;                 // [joint]: the pose the skeleton was built in
  double frame_time = 0;                       // seconds
  std::vector<std::vector<JointPose>> frames;  // [frame][joint]

  int num_frames() const { return static_cast<int>(frames.size()); }
  // The joint called `name` (not end sites), or -1; a name with a namespace ("mixamorig:Hips")
  // also matches a joint without one, and the other way round.
  int Find(const std::string& name) const;
};

// A BVH file's skeleton, rest pose (every channel zero) and frames by forward kinematics.
SkeletonAnimation FromBvh(const BvhMotion& bvh);

}  // namespace ragdoll::motion
