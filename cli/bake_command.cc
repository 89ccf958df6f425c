#include "cli/bake_command.h"

#include <memory>

#include "exports/bake.h"

namespace ragdoll::cli {

std::function<int()> AddBakeCommand(CLI::App& app) {
  auto o = std::make_shared<exports::BakeOptions>();
  auto* cmd = app.add_subcommand("bake",
                                 "the trained policy's simulated motion as an animation file (BVH, "
                                 "FBX, glTF binary)");
  cmd->add_option("run", o->target, "run folder or checkpoint")->required();
  cmd->add_option("--out", o->out,
                  "file to write: .bvh, .glb, .fbx (by Blender), or .json "
                  "(the project's clip format)")
      ->required();
  cmd->add_option("--seconds", o->seconds,
                  "how long to simulate (default: a one-shot clip's length, else 10 s)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--fps", o->fps, "resample to this frame rate (default: the control rate)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--naming", o->naming,
                  "bone names: a mapping preset (ragdoll, mixamo, cmu) or YAML file")
      ->capture_default_str();
  cmd->add_option("--commands", o->commands, "steering runs: a command script file")
      ->check(CLI::ExistingFile);
  cmd->add_option("--phase", o->phase, "the clip's phase to start from, 0..1")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--units", o->units, "m or cm (default: m)")->check(CLI::IsMember({"m", "cm"}));
  cmd->add_option("--up", o->up, "y or z")->check(CLI::IsMember({"y", "z"}))->capture_default_str();
  cmd->add_option("--pushes", o->pushes,
                  "bake reactions: push the pelvis with this impulse (N s, over 0.2 s) in a random "
                  "horizontal direction every --push-every seconds")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--push-every", o->push_every, "seconds between pushes (--pushes)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--seed", o->seed, "episode seed (and push directions)")->capture_default_str();
  return [cmd, o]() -> int {
    if (!*cmd) return -1;
    exports::Bake(*o);
    return 0;
  };
}

}  // namespace ragdoll::cli
