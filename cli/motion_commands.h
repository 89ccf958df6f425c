// `ragdoll motion import|export|inspect`: bring an animation (BVH, FBX, glTF, COLLADA) onto the
// character, write a clip as BVH, and check a clip for what a simulated character cannot reproduce.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "character/motion_clip.h"

namespace ragdoll::cli {

// Adds the `motion` command and its subcommands to `app`; the returned callback runs whichever
// was chosen (returns the exit code), or -1 when `motion` was not on the command line.
std::function<int()> AddMotionCommands(CLI::App& app);

struct ImportedMotion {
  character::MotionClip clip;
  std::vector<std::string> notes;  // what the import decided, a line each
  std::string description;         // where the clip came from
};

// A file as `ragdoll train --motion` takes it: the project's clips (.json) and DeepMimic's (.txt)
// as they are; BVH, FBX, glTF and COLLADA through `motion import`'s defaults (mapping auto, root
// motion auto, feet cleaned where the clip needs it), marked as a loop when the last frame is the
// first pose again (motion/clip_kind.h). Throws ConfigError or std::runtime_error naming the file.
ImportedMotion ImportMotionFile(const std::string& path);

}  // namespace ragdoll::cli
