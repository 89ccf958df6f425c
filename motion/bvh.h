// BVH motion capture files as animation tools write them (Blender, Maya, MotionBuilder, the CMU
// and Mixamo libraries): a joint hierarchy with offsets and per-joint channels in any order, then
// one line of channel values per frame. Parsing only; retargeting onto the project's character
// lives in motion/retarget.h.
#pragma once

#include <string>
#include <vector>

#include "character/rotation.h"

namespace ragdoll::motion {

enum class BvhChannel { kXposition, kYposition, kZposition, kXrotation, kYrotation, kZrotation };

struct BvhJoint {
  std::string name;  // "End Site" leaves are named "<parent>_end"
  int parent = -1;   // index into BvhMotion::joints; -1 for the root
  character::Vec3 offset = {0, 0, 0};
  std::vector<BvhChannel> channels;  // in file order; empty for end sites
  int first_channel = 0;             // index of channels[0] in a frame's values
  bool end_site = false;
};

struct BvhMotion {
  std::string origin;                       // file name, for messages
  std::vector<BvhJoint> joints;             // parents before children (file order)
  int channel_count = 0;                    // values per frame
  double frame_time = 0;                    // seconds
  std::vector<std::vector<double>> frames;  // [frame][channel], as in the file (degrees, units)
  std::vector<std::string> notes;           // what the reader tolerated, "file:line: what"

  int num_frames() const { return static_cast<int>(frames.size()); }
  // Index of the joint called `name` (not end sites), or -1.
  int Find(const std::string& name) const;
  // The joint's rotation relative to its parent at a frame: the product of its rotation
  // channels in file order (BVH's convention), degrees converted. Identity without channels.
  character::Quat LocalRotation(int frame, int joint) const;
  // The joint's translation relative to its parent at a frame: its offset, replaced per axis by
  // any position channels (the root's usually).
  character::Vec3 LocalTranslation(int frame, int joint) const;
};

// Parses BVH text; `origin` names it in errors. Throws ConfigError "origin:line: reason" for a
// bad hierarchy, a channel count that does not match, a truncated motion section or a value
// that is not a finite number. Lines beyond the declared frame count are ignored, with a note.
BvhMotion ParseBvh(const std::string& text, const std::string& origin);
BvhMotion LoadBvh(const std::string& path);

}  // namespace ragdoll::motion
