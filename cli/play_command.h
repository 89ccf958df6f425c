// `ragdoll play RUN`: a trained steerable character in a window, steered with the keyboard in
// real time (arrows or WASD walk and strafe, Q/E turn, space pushes, R resets).
#pragma once

#include <CLI/CLI.hpp>

#include <atomic>
#include <functional>

namespace ragdoll::cli {

// Adds `play` to `app`; the callback runs it (exit code) or returns -1 when not chosen. `stop`
// (SIGINT, SIGTERM) ends it as closing the window does.
std::function<int()> AddPlayCommand(CLI::App& app, const std::atomic<bool>& stop);

}  // namespace ragdoll::cli
