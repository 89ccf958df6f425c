// `ragdoll doctor [CONFIG]`: what this machine can do and what the project makes of it. The CPU
// and the BLAS kernels running (and each kernel set the CPU could run, timed in a child
// process), raw mj_step, the actor's samples/s against it, the PPO update's against raw libtorch
// forward+backward+Adam, the bound these put on a training of CONFIG on this machine's cores,
// and what it would change. `--train SECONDS` also runs `ragdoll train CONFIG` that long and
// sets its samples/s against the bound; `--json FILE` writes the same figures.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace ragdoll::cli {

// Adds `doctor` to `app`; the callback runs it (exit code) or returns -1 when not chosen.
std::function<int()> AddDoctorCommand(CLI::App& app);

}  // namespace ragdoll::cli
