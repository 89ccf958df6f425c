// `ragdoll export RUN_OR_CHECKPOINT --onnx FILE [--value] [--sidecar FILE] [--run FOLDER]`: the
// trained policy as an ONNX model for game engines (exports/onnx_export.h), and beside it a JSON
// sidecar with everything an engine integration needs to feed and drive it: the observation's
// layout, each action axis and how an action becomes a PD target, the control rate, the character
// and clip (exports/sidecar.h, docs/engine-integration.md); or the run as a folder to ship
// (exports/run_folder.h). The command parses its arguments and reports; exports/ does the work.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace ragdoll::cli {

// Adds `export` to `app`; the callback runs it (exit code) or returns -1 when not chosen.
std::function<int()> AddExportCommand(CLI::App& app);

}  // namespace ragdoll::cli
