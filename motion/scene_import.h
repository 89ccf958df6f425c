// Reading skeletal animation from the files animation tools write: BVH with the project's parser
// (motion/bvh.h), and through Assimp the scene formats FBX (binary and ASCII, Mixamo's
// downloads), glTF 2 (.gltf, .glb) and COLLADA (.dae). A scene's skeleton is the smallest subtree
// holding every node the animation moves; its rest pose is the nodes' own transforms. Meshes
// (skinned or not), cameras and lights are ignored, with a note.
#pragma once

#include <string>
#include <vector>

#include "motion/skeleton_animation.h"

namespace ragdoll::motion {

struct AnimationInfo {
  std::string name;
  double duration = 0;  // seconds
  int channels = 0;     // nodes it moves
};

// The animations of a scene file, in file order (one, unnamed, for a BVH file). Throws
// ConfigError naming the file when it cannot be read.
std::vector<AnimationInfo> ListAnimations(const std::string& path);

// The skeleton and frames of one animation of `path`: `animation` is a name or an index into
// ListAnimations; empty takes the first that moves anything. Frames are sampled at the keys'
// own spacing (baked animation: one key per frame), or at 30 frames/s when keys are sparse.
// What was ignored or chosen goes to `notes`. Throws ConfigError naming the file and the
// problem: unreadable, malformed or truncated, no animation, no such animation.
// BVH files go to the project's parser unless `bvh_reader` says Assimp's (measured against each
// other on real captures in docs/motion-import.md).
enum class BvhReader { kRagdoll, kAssimp };
SkeletonAnimation LoadSkeletonAnimation(const std::string& path, const std::string& animation = "",
                                        std::vector<std::string>* notes = nullptr,
                                        BvhReader bvh_reader = BvhReader::kRagdoll);

}  // namespace ragdoll::motion
