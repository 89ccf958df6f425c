#include "cli/bake_command.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "actor/command_evaluation.h"
#include "actor/rollout.h"
#include "actor/run_pushes.h"
#include "actor/sim/motion_io.h"
#include "cli/child_process.h"
#include "cli/trained_policy.h"
#include "common/config_section.h"
#include "motion/retarget.h"
#include "motion/scene_export.h"

namespace ragdoll::cli {
namespace {

struct BakeOptions {
  std::string target, out, naming = "ragdoll", commands, units, up = "y";
  double seconds = 0;  // 0: a one-shot clip's length, 10 s otherwise
  double fps = 0;      // 0: the control rate
  double phase = 0;
  uint64_t seed = 1;
  double pushes = 0;      // N s on the pelvis, 0: none
  double push_every = 2;  // s
};

// Blender converts the baked BVH to FBX (motion/blender/convert.py): Assimp 5.2's FBX writer
// made files that neither Blender nor Assimp read back. RAGDOLL_BLENDER names another
// Blender than the one on the PATH.
constexpr double kBlenderTimeoutSeconds = 600;

void ConvertWithBlender(const std::string& bvh_text, const std::string& out) {
  const char* chosen = std::getenv("RAGDOLL_BLENDER");
  const std::string blender = chosen && *chosen ? chosen : "blender";
  // The BVH's name becomes the armature's and the animation's in the FBX: the output's own.
  std::string folder = (std::filesystem::temp_directory_path() / "ragdoll-bake.XXXXXX").string();
  if (!mkdtemp(folder.data())) throw std::runtime_error(folder + ": cannot create");
  struct RemoveOnExit {
    std::string path;
    ~RemoveOnExit() {
      std::error_code ignored;
      std::filesystem::remove_all(path, ignored);
    }
  } remove_folder{folder};
  const std::string bvh = folder + "/" + std::filesystem::path(out).stem().string() + ".bvh";
  const std::string log = out + ".blender.log";
  {
    std::ofstream file(bvh);
    file << bvh_text;
    if (!file.flush()) throw std::runtime_error(bvh + ": cannot write");
  }
  const int code =
      RunProcess({blender, "-b", "--factory-startup", "--python",
                  std::string(RAGDOLL_BLENDER_SCRIPTS_DIR) + "/convert.py", "--", bvh, out},
                 log, kBlenderTimeoutSeconds);
  if (code == 127) {
    std::filesystem::remove(log);
    throw ConfigError("bake --out " + out + ": FBX is written by Blender, and '" + blender +
                      "' could not be run (apt install blender, or set RAGDOLL_BLENDER); .bvh "
                      "and .glb need nothing more");
  }
  if (code != 0 || !std::filesystem::exists(out)) {
    throw std::runtime_error("bake --out " + out + ": Blender did not write it (" +
                             (code < 0 ? "timed out" : "exit code " + std::to_string(code)) +
                             "): " + LastLine(log) + "; its log: " + log);
  }
  std::filesystem::remove(log);
}

int Bake(const BakeOptions& o) {
  const std::string format = motion::SceneExportFormat(o.out);
  const std::string ext = std::filesystem::path(o.out).extension().string();
  const bool bvh = ext == ".bvh", json = ext == ".json";
  if (ext == ".dae") {
    throw ConfigError("bake --out " + o.out +
                      ": COLLADA is not written: Assimp 5.2's COLLADA file came into Blender with "
                      "one frame of its animation, and Blender 3.4's own came back into Blender "
                      "6.9 degrees off with its frame rate lost; write .fbx, .glb or .bvh");
  }
  const bool by_blender = ext == ".fbx";
  if (!bvh && !json && !by_blender && format.empty()) {
    throw ConfigError("bake --out " + o.out + ": give a .bvh, .fbx, .glb or .json file");
  }
  const TrainedPolicy policy = LoadTrainedPolicy(o.target);
  sim::EnvConfig env = policy.experiment.environment;
  if (!o.commands.empty() && !env.steering.enabled()) {
    throw ConfigError("bake --commands: " + policy.checkpoint +
                      " was not trained with a steering task (environment.steering)");
  }
  auto character = sim::Character::Load(env.character, env.physics_dt());
  const sim::MotionClip reference = sim::LoadMotion(env.motion);
  actor::CommandScript script;
  if (!o.commands.empty()) {
    script = actor::ReadCommandScript(o.commands, *sim::LoadMotionSet(env, *character), *character);
  }
  const double rate = env.control_frequency;
  const double seconds = o.seconds > 0         ? o.seconds
                         : script.duration > 0 ? script.duration
                         : !reference.loop()   ? reference.duration()
                                               : 10.0;
  const int steps = std::max(1, static_cast<int>(std::lround(seconds * rate)));
  // One episode throughout: no time limit restarts the character half-way, and a push that
  // carries it away from the reference ends nothing but a fall.
  env.max_episode_steps = std::max(env.max_episode_steps, steps + 1);
  if (o.pushes > 0) env.max_root_distance = std::numeric_limits<double>::infinity();
  actor::RolloutWorker worker(env, 1, 1, o.seed, "bake");
  worker.SetPolicy(policy.snapshot);
  sim::ImitationEnv& e = worker.environment(0);
  size_t next_change = 0;
  if (env.steering.enabled()) {
    if (script.changes.empty()) {
      script.changes = {{0, e.motion_set().entry(e.motion_set().commands().front()).name}};
    }
    worker.SetCommandFirst(e.motion_set().Find(script.changes.front().command));
    next_change = 1;
  }
  worker.ResetFirst(o.phase);

  std::vector<sim::Pose> frames = {character->QposToPose(e.data().qpos)};
  std::string ending = "";
  actor::RandomPushes pushes(o.pushes, o.pushes, o.pushes > 0 ? o.push_every : 0, 1 / rate, o.seed,
                             character->root_body());
  actor::ScriptedPushes scripted(script.pushes, *character);
  for (int s = 1; s <= steps; ++s) {
    if (next_change < script.changes.size() && script.changes[next_change].at <= (s - 1) / rate) {
      worker.SetCommandFirst(e.motion_set().Find(script.changes[next_change++].command));
    }
    if (pushes.Before(e, s - 1)) {
      std::fprintf(stderr, "bake: push at %.2f s: %.0f N s on the pelvis toward %.0f deg\n",
                   (s - 1) / rate, pushes.last_impulse(), pushes.last_angle() * 180 / M_PI);
    }
    scripted.Before(e, (s - 1) / rate);
    const sim::StepResult r = worker.StepFirst(true);
    frames.push_back(character->QposToPose(e.data().qpos));
    if (r.terminated || r.truncated) {
      char line[200];
      std::snprintf(line, sizeof line, "; the episode %s at %.2f s",
                    r.terminated ? "ended with a fall" : "ended with its clip", e.time());
      ending = line;
      break;
    }
  }
  if (pushes.count() > 0) {
    char line[120];
    std::snprintf(line, sizeof line, "; %d push%s%s", pushes.count(),
                  pushes.count() == 1 ? "" : "es",
                  e.episode().task_falls > 0 ? ", fell and got up" : "");
    ending += line;
  }
  std::vector<double> durations(frames.size(), 1 / rate);
  const int simulated = static_cast<int>(frames.size());
  sim::MotionClip clip(reference.name() + "_baked", false, std::move(durations), std::move(frames));
  if (o.fps > 0) clip = motion::Resampled(clip, o.fps);

  if (json) {  // the project's own clip format: what `motion import` of the others gives back
    sim::SaveClip(clip, "baked from " + policy.checkpoint, o.out);
    std::fprintf(stderr, "bake: %s: %.2f s simulated%s -> %s: %d frames\n",
                 policy.checkpoint.c_str(), (simulated - 1) / rate, ending.c_str(), o.out.c_str(),
                 clip.num_frames());
    return 0;
  }
  motion::ExportOptions options;
  options.y_up = o.up == "y";
  const std::string units = !o.units.empty() ? o.units : "m";
  options.units_per_metre = units == "cm" ? 100 : 1;
  const std::string text = motion::FormatBvh(
      motion::ClipToBvh(clip, *character, motion::ReadJointMapping(o.naming), options));
  if (bvh) {
    std::ofstream out(o.out);
    out << text;
    if (!out) throw std::runtime_error(o.out + ": cannot write");
  } else if (by_blender) {
    ConvertWithBlender(text, o.out);
  } else {
    motion::ExportBvhAsScene(text, o.out);
  }
  std::fprintf(stderr,
               "bake: %s (policy v%lld): %.2f s simulated at %.0f Hz%s -> %s: %d frames at %.1f "
               "frames/s, %s joint names, %s, %s-up\n",
               policy.checkpoint.c_str(), static_cast<long long>(policy.version),
               (simulated - 1) / rate, rate, ending.c_str(), o.out.c_str(), clip.num_frames(),
               (clip.num_frames() - 1) / clip.duration(), o.naming.c_str(), units.c_str(),
               o.up.c_str());
  return 0;
}

}  // namespace

std::function<int()> AddBakeCommand(CLI::App& app) {
  auto o = std::make_shared<BakeOptions>();
  auto* cmd = app.add_subcommand("bake",
                                 "the trained policy's simulated motion as an animation file (BVH, "
                                 "FBX, glTF binary, COLLADA)");
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
    return Bake(*o);
  };
}

}  // namespace ragdoll::cli
