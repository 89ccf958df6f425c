// Retargeting skeletal motion (BVH, FBX, glTF, COLLADA: motion/scene_import.h) onto the
// project's character, and exporting clips as BVH.
//
// Import works on bone directions and rotations, not on joint names alone: each character
// segment (pelvis, chest, neck, thighs, shins, feet, upper arms, forearms) is driven by one
// source joint named in a mapping (a file, or found by `--map auto`: motion/auto_mapping.h). The
// rest poses of the two skeletons are aligned once per segment (bone direction plus a twist
// reference), so a T-posed mocap skeleton drives the arms-down character correctly; every frame, a
// segment's world rotation is the BVH joint's world rotation composed with that alignment. BVH
// joints the character lacks (extra spine, clavicle, neck joints) are folded in because world
// rotations include every joint above them; parts the mapping leaves out stay at rest. Knees and
// elbows, single hinges on the character, take their hinge axis from the motion where it bends
// them enough to show it (so a file whose "rest" pose is really a bent frame still bends them
// right); the thigh's and upper arm's twist follow from it. The up axis,
// facing direction and units are found from the BVH's rest pose (hips, spine, legs), so Y-up and
// Z-up files in centimetres or metres import alike.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "character/character.h"
#include "character/motion_clip.h"
#include "motion/bvh.h"
#include "motion/skeleton_animation.h"

namespace ragdoll::motion {

// Character parts a mapping names, e.g. "left_knee: LeftLeg".
const std::vector<std::string>& MappingParts();

struct JointMapping {
  std::string origin;                         // file it came from
  std::map<std::string, std::string> joints;  // part -> BVH joint name
};

// A preset (a file name in assets/mappings/ without .yaml: "cmu", "mixamo", "ragdoll") or a
// YAML file of `part: BvhJointName` lines. Throws ConfigError naming the file, line and key.
JointMapping ReadJointMapping(const std::string& preset_or_path);

struct ImportOptions {
  std::string name;     // clip name (default: the file's stem)
  int first_frame = 0;  // trim: first BVH frame used
  int last_frame = -1;  // trim: last BVH frame used; -1 = the last
  double fps = 0;       // resample to this frame rate; 0 keeps the file's
  bool mirror = false;  // swap left and right
  bool loop = false;    // mark the clip as looping (its last frame should close the cycle)
  double scale = 0;     // metres per BVH unit; 0 = from leg length
  // How each foot's rest alignment is chosen. kFloor: from the frames where the source's own
  // ankle and toe are planted, so that a foot flat on the floor in the capture is flat on the
  // character's floor. kRest: from the rest pose alone, like every other segment.
  enum class Feet { kFloor, kRest } feet = Feet::kFloor;
};

// Throws ConfigError naming the file and the problem (no root joint, an unusable rest pose,
// a bad frame range). Mapped joints the file lacks are reported in `warnings` and stay at rest;
// decisions worth knowing (the foot alignment found) are reported there too.
character::MotionClip Retarget(const SkeletonAnimation& source, const JointMapping& mapping,
                               const character::Character& character, const ImportOptions& options,
                               std::vector<std::string>* warnings = nullptr);

// The clip at `fps`: whole intervals over the same duration (a loop still closes exactly).
character::MotionClip Resampled(const character::MotionClip& clip, double fps);

struct ExportOptions {
  std::string rotation_order = "ZXY";  // channel order of every joint's rotation
  double units_per_metre = 1;          // 100 writes centimetres
  bool y_up = false;                   // Y-up (most tools) instead of the project's Z-up
};

// The clip on the character's skeleton as BVH, joints named by `naming` (e.g. the CMU preset),
// one frame per clip key frame (the clip's own frame times must be uniform).
BvhMotion ClipToBvh(const character::MotionClip& clip, const character::Character& character,
                    const JointMapping& naming, const ExportOptions& options);
std::string FormatBvh(const BvhMotion& bvh);

}  // namespace ragdoll::motion
