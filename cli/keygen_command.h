// `ragdoll keygen [NAME] [--role broker|actor|learner] [--keys DIR] [--force]`: CURVE key pairs
// in ZeroMQ's certificate format, laid out as the roles look for them (common/keys.h).
// Without NAME: the three pairs one training needs (broker, actor, learner).
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace ragdoll::cli {

// Adds `keygen` to `app`; the callback runs it (exit code) or returns -1 when not chosen.
std::function<int()> AddKeygenCommand(CLI::App& app);

}  // namespace ragdoll::cli
