// `ragdoll train CONFIG`: one broker, one learner and N actors as child processes of this binary
// on loopback; stops them all (the learner last but one, so it writes a final checkpoint) on
// Ctrl-C or when the learner finishes.
#pragma once

#include <CLI/CLI.hpp>

#include <atomic>
#include <functional>

namespace ragdoll::cli {

// Adds `train` to `app`; the callback runs it until `stop` (SIGINT, SIGTERM) or the learner's end
// (exit code), or returns -1 when not chosen.
std::function<int()> AddTrainCommand(CLI::App& app, const std::atomic<bool>& stop);

}  // namespace ragdoll::cli
