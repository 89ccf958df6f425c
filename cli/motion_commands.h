// `ragdoll motion import|export|inspect`: bring an animation (BVH, FBX, glTF, COLLADA) onto the
// character, write a clip as BVH, and check a clip for what a simulated character cannot reproduce.
#pragma once

#include <CLI/CLI.hpp>

namespace ragdoll::cli {

// Adds the `motion` command and its subcommands to `app`; the returned callback runs whichever
// was chosen (returns the exit code), or -1 when `motion` was not on the command line.
std::function<int()> AddMotionCommands(CLI::App& app);

}  // namespace ragdoll::cli
