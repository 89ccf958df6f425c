// ragdoll: one binary for every role.
//   ragdoll train CONFIG         broker + learner + actors on this machine
//   ragdoll broker|learner|actor CONFIG   one role, for distributed runs
//   ragdoll eval RUN_OR_CHECKPOINT       deterministic evaluation, JSON out (and RUN/eval.json);
//                                        --commands SCRIPT|random scores a steering policy
//   ragdoll export RUN_OR_CHECKPOINT --onnx FILE   the policy as ONNX, with a JSON sidecar
//   ragdoll render [RUN_OR_CHECKPOINT] --clip CLIP --out FILE.mp4|.gif|.png
//   ragdoll play RUN_OR_CHECKPOINT      steer a trained steering run with the keyboard
//   ragdoll motion import|export|inspect   bring BVH clips onto the character, check clips
//   ragdoll report RUN [RUN ...] --out FILE.html   curves, evaluation and a GIF of runs, one page
//   ragdoll keygen [NAME]                CURVE keys for authenticated, encrypted transport
//   ragdoll verify RUN_OR_CHECKPOINT...  checkpoints whole, loadable, finite
//   ragdoll doctor [CONFIG]              this machine's limits and the training's ratios to them
//   ragdoll bake RUN_OR_CHECKPOINT --out FILE.bvh|.fbx|.glb   the simulated motion, for a DCC
#include <signal.h>
#include <CLI/CLI.hpp>

#include <atomic>
#include <cstdio>
#include <functional>
#include <string>

#include "cli/bake_command.h"
#include "cli/doctor_command.h"
#include "cli/eval_command.h"
#include "cli/export_command.h"
#include "cli/keygen_command.h"
#include "cli/launcher.h"
#include "cli/motion_commands.h"
#include "cli/play_command.h"
#include "cli/render_command.h"
#include "cli/report_command.h"
#include "cli/role_commands.h"
#include "cli/verify_command.h"
#include "common/allocator.h"
#include "common/blas.h"
#include "common/config_section.h"

namespace {

std::atomic<bool> g_stop{false};

void OnSignal(int) { g_stop.store(true); }

void InstallSignalHandlers() {
  struct sigaction action = {};
  action.sa_handler = OnSignal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

// CLI11 answers `--help` before it notices an unknown command, so `ragdoll typo --help` would
// print the main help and succeed; the command word is checked first.
bool IsKnownCommand(const CLI::App& app, const std::string& word) {
  if (word.empty() || word[0] == '-') return true;
  for (const CLI::App* command : app.get_subcommands([](const CLI::App*) { return true; })) {
    if (command->check_name(word)) return true;
  }
  return false;
}

std::string CommandNames(const CLI::App& app) {
  std::string names;
  for (const CLI::App* command : app.get_subcommands([](const CLI::App*) { return true; })) {
    names += (names.empty() ? "" : ", ") + command->get_name();
  }
  return names;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace ragdoll;
  blas::ChooseKernels(argv);  // may execute this program again, before anything else has run
  allocator::KeepLargeBlocks();
  CLI::App app("ragdoll: train physics-simulated characters to imitate animation clips.");
  app.require_subcommand(1);
  // Each command adds itself; its callback runs it (exit code) or returns -1 when not chosen.
  const std::function<int()> commands[] = {cli::AddTrainCommand(app, g_stop),
                                           cli::AddRoleCommands(app, g_stop),
                                           cli::AddEvalCommand(app),
                                           cli::AddMotionCommands(app),
                                           cli::AddRenderCommand(app, argc, argv),
                                           cli::AddPlayCommand(app, g_stop),
                                           cli::AddReportCommand(app),
                                           cli::AddKeygenCommand(app),
                                           cli::AddVerifyCommand(app),
                                           cli::AddExportCommand(app),
                                           cli::AddDoctorCommand(app),
                                           cli::AddBakeCommand(app)};
  if (argc > 1 && !IsKnownCommand(app, argv[1])) {
    std::fprintf(stderr, "ragdoll: unknown command '%s' (commands: %s)\n", argv[1],
                 CommandNames(app).c_str());
    return 2;
  }
  CLI11_PARSE(app, argc, argv);
  InstallSignalHandlers();
  try {
    for (const auto& command : commands) {
      if (int code = command(); code >= 0) return code;
    }
  } catch (const ConfigError& error) {
    std::fprintf(stderr, "ragdoll: %s\n", error.what());
    return 2;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "ragdoll: error: %s\n", error.what());
    return 1;
  }
  return 0;
}
