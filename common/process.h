// Other programs the commands run (xvfb-run, rsvg-convert, Blender): started with their output in
// a log, waited for with a time limit, ended with everything they started.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace ragdoll::cli {

// Runs `args` (args[0] a path or a name looked up in PATH) with stdout and stderr into `log`, in
// a process group of its own so that a timeout or Ctrl-C ends everything it started (xvfb-run
// starts Xvfb, render starts ffmpeg). Returns the exit code, 127 when the program could not be
// started, -1 after the timeout; throws when interrupted.
int RunProcess(const std::vector<std::string>& args, const std::filesystem::path& log,
               double timeout_seconds);

// The last non-empty line of a log, for a one-line reason.
std::string LastLine(const std::filesystem::path& log);

}  // namespace ragdoll::cli
