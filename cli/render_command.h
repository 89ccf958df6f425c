// `ragdoll render [RUN_OR_CHECKPOINT] --clip CLIP --out FILE.mp4|.gif|.png`: the trained ragdoll
// next to its reference clip, or the clip alone without a policy.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace ragdoll::cli {

// Adds `render` to `app`; the callback runs it (exit code) or returns -1 when not chosen.
// Without an X display it runs itself again under xvfb-run (argc/argv for that).
std::function<int()> AddRenderCommand(CLI::App& app, int argc, char** argv);

}  // namespace ragdoll::cli
