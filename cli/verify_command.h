// `ragdoll verify RUN_OR_CHECKPOINT...`: every checkpoint of the runs (or the files given) is
// whole (checksum), loads into the run's learner, and holds only finite weights and statistics.
// One line per checkpoint; exit code 1 when any is not.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace ragdoll::cli {

// Adds `verify` to `app`; the callback runs it (exit code) or returns -1 when not chosen.
std::function<int()> AddVerifyCommand(CLI::App& app);

}  // namespace ragdoll::cli
