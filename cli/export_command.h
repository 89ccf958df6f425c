// `ragdoll export RUN_OR_CHECKPOINT --onnx FILE [--value] [--sidecar FILE]`: the trained policy
// as an ONNX model for game engines (cli/onnx_export.h), and beside it a JSON sidecar with
// everything an engine integration needs to feed and drive it: the observation's layout, each
// action axis and how an action becomes a PD target, the control rate, the character and clip
// (docs/engine-integration.md).
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace ragdoll::cli {

// Adds `export` to `app`; the callback runs it (exit code) or returns -1 when not chosen.
std::function<int()> AddExportCommand(CLI::App& app);

}  // namespace ragdoll::cli
