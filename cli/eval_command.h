// `ragdoll eval RUN_OR_CHECKPOINT`: deterministic evaluation of a trained policy, JSON out (and
// RUN/eval.json); --pushes adds push trials, --commands SCRIPT|random scores a steering policy.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace ragdoll::cli {

// Adds `eval` to `app`; the callback runs it (exit code) or returns -1 when not chosen.
std::function<int()> AddEvalCommand(CLI::App& app);

}  // namespace ragdoll::cli
