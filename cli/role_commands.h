// `ragdoll broker|learner|actor CONFIG --run-id ID`: one role of a distributed run, as a container
// or a host runs it. Each reads its options from RAGDOLL_* environment variables too (for
// containers); a command-line option wins over its variable.
#pragma once

#include <CLI/CLI.hpp>

#include <atomic>
#include <functional>

namespace ragdoll::cli {

// Adds `broker`, `learner` and `actor` to `app`; the callback runs the chosen role until `stop`
// (SIGINT, SIGTERM) or its end (exit code), or returns -1 when none was chosen.
std::function<int()> AddRoleCommands(CLI::App& app, const std::atomic<bool>& stop);

}  // namespace ragdoll::cli
