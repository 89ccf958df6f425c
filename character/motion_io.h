// Reading and writing motion clips: the project's own clip format and DeepMimic motion files.
#pragma once

#include <string>

#include "character/motion_clip.h"

namespace ragdoll::character {

// Reads a clip in the project's format (JSON; see assets/motions/README.md) or, recognised by
// its "Frames" key, a DeepMimic motion file (Y-up, converted to this project's Z-up frame).
// Throws ragdoll::ConfigError naming the file, frame and field of the first problem.
MotionClip LoadMotion(const std::string& path);

// The same, from text already in memory; `origin` names it in error messages.
MotionClip ParseMotion(const std::string& text, const std::string& origin);

// The clip in the project's format, with six decimals (micrometres, microradians).
std::string FormatClip(const MotionClip& clip, const std::string& description);
// Writes FormatClip() to `path` atomically (temporary file, then rename).
void SaveClip(const MotionClip& clip, const std::string& description, const std::string& path);

// DeepMimic (Y-up, +Z right) to this project (Z-up, +X forward, +Y left): (x, y, z) -> (x, -z, y).
Vec3 FromYUp(const Vec3& v);
Quat FromYUp(const Quat& q);

}  // namespace ragdoll::character
