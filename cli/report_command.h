// `ragdoll report RUN [RUN ...] --out report.html [--png curves.png] [--no-gif]`: one
// self-contained HTML page with the runs' training curves overlaid, their latest evaluation and
// a GIF of each newest policy beside its reference.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace ragdoll::cli {

// Adds `report` to `app`; the callback runs it (exit code) or returns -1 when not chosen.
std::function<int()> AddReportCommand(CLI::App& app);

}  // namespace ragdoll::cli
