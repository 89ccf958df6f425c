// `ragdoll bake RUN --out FILE`: the trained policy's simulated performance written as an
// animation of the character's skeleton (BVH, glTF binary, or the project's clip format), for
// animators and engines without a physics runtime. The command parses its options; the baking is
// exports/bake.h.
#pragma once

#include <CLI/CLI.hpp>

namespace ragdoll::cli {

// Adds the `bake` command to `app`; the returned callback runs it (returns the exit code), or
// returns -1 when `bake` was not on the command line.
std::function<int()> AddBakeCommand(CLI::App& app);

}  // namespace ragdoll::cli
