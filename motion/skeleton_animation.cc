#include "motion/skeleton_animation.h"

#include "character/vector.h"

namespace ragdoll::motion {

using character::Add;
using character::kIdentityQuat;
using character::Multiply;
using character::Normalized;
using character::Quat;
using character::Rotate;
using character::Vec3;

namespace {

std::string Bare(const std::string& name) { return name.substr(name.rfind(':') + 1); }

// World poses of every joint for local rotations and translations given per joint.
template <typename Local>
std::vector<JointPose> ForwardKinematics(const BvhMotion& bvh, Local local) {
  std::vector<JointPose> world(bvh.joints.size());
  for (size_t j = 0; j < bvh.joints.size(); ++j) {
    auto [rotation, translation] = local(static_cast<int>(j));
    const int parent = bvh.joints[j].parent;
    if (parent < 0) {
      world[j] = {rotation, translation};
    } else {
      world[j].rotation = Normalized(Multiply(world[parent].rotation, rotation));
      world[j].position = Add(world[parent].position, Rotate(world[parent].rotation, translation));
    }
  }
  return world;
}

}  // namespace

int SkeletonAnimation::Find(const std::string& name) const {
  for (size_t i = 0; i < joints.size(); ++i) {
    if (!joints[i].end_site && joints[i].name == name) return static_cast<int>(i);
  }
  const std::string wanted = Bare(name);
  for (size_t i = 0; i < joints.size(); ++i) {
    if (!joints[i].end_site && Bare(joints[i].name) == wanted) return static_cast<int>(i);
  }
  return -1;
}

SkeletonAnimation FromBvh(const BvhMotion& bvh) {
  SkeletonAnimation animation;
  animation.origin = bvh.origin;
  animation.format = "BVH";
  animation.frame_time = bvh.frame_time;
  for (const BvhJoint& j : bvh.joints) animation.joints.push_back({j.name, j.parent, j.end_site});
  animation.rest = ForwardKinematics(bvh, [&](int j) {
    return std::pair<Quat, Vec3>{kIdentityQuat, bvh.joints[j].offset};
  });
  animation.frames.reserve(bvh.frames.size());
  for (int f = 0; f < bvh.num_frames(); ++f) {
    animation.frames.push_back(ForwardKinematics(bvh, [&](int j) {
      return std::pair<Quat, Vec3>{bvh.LocalRotation(f, j), bvh.LocalTranslation(f, j)};
    }));
  }
  return animation;
}

}  // namespace ragdoll::motion
