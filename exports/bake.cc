#include "exports/bake.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <stdexcept>
#include <utility>
#include <vector>

#include "actor/rollout.h"
#include "character/character.h"
#include "character/motion_clip.h"
#include "character/motion_io.h"
#include "common/config_section.h"
#include "common/process.h"
#include "eval/command_evaluation.h"
#include "eval/scripted_pushes.h"
#include "motion/retarget.h"
#include "motion/scene_export.h"
#include "run/trained_policy.h"
#include "sim/motion_set.h"

namespace ragdoll::exports {
namespace {
namespace fs = std::filesystem;

// What the output's extension asks for.
enum class BakeOutput { kJson, kBvh, kFbx, kScene };

// The output's kind. Throws ConfigError for COLLADA (the message says why) and for an extension
// nothing here writes.
BakeOutput OutputKind(const std::string& out) {
  const std::string format = motion::SceneExportFormat(out);
  const std::string ext = fs::path(out).extension().string();
  if (ext == ".dae") {
    throw ConfigError("bake --out " + out +
                      ": COLLADA is not written: Assimp 5.2's COLLADA file came into Blender with "
                      "one frame of its animation, and Blender 3.4's own came back into Blender "
                      "6.9 degrees off with its frame rate lost; write .fbx, .glb or .bvh");
  }
  if (ext == ".json") return BakeOutput::kJson;
  if (ext == ".bvh") return BakeOutput::kBvh;
  if (ext == ".fbx") return BakeOutput::kFbx;
  if (format.empty())
    throw ConfigError("bake --out " + out + ": give a .bvh, .fbx, .glb or .json file");
  return BakeOutput::kScene;
}

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

// What one bake simulates: the policy in its own environment, changed so that nothing but a fall
// ends the episode, for `steps` control steps.
struct Performance {
  run::TrainedPolicy policy;
  sim::EnvConfig env;
  std::shared_ptr<const character::Character> character;
  character::MotionClip reference;
  eval::CommandScript script;
  double rate = 0;  // control steps per second
  int steps = 0;
};

Performance Prepare(const BakeOptions& o) {
  run::TrainedPolicy policy = run::LoadTrainedPolicy(o.target);
  sim::EnvConfig env = policy.experiment.environment;
  if (!o.commands.empty() && !env.steering.enabled()) {
    throw ConfigError("bake --commands: " + policy.checkpoint +
                      " was not trained with a steering task (environment.steering)");
  }
  auto character = character::Character::Load(env.character, env.physics_dt());
  character::MotionClip reference = character::LoadMotion(env.motion);
  eval::CommandScript script;
  if (!o.commands.empty()) {
    script = eval::ReadCommandScript(o.commands, *sim::LoadMotionSet(env, *character), *character);
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
  return {std::move(policy),
          std::move(env),
          std::move(character),
          std::move(reference),
          std::move(script),
          rate,
          steps};
}

// Resets environment 0 of `worker` at `phase`, steering runs first given the script's first
// command (the motion set's first command when the script gives none). Returns the index of the
// script's next command change.
size_t StartEpisode(actor::RolloutWorker& worker, const sim::EnvConfig& env,
                    eval::CommandScript* script, double phase) {
  sim::ImitationEnv& e = worker.environment(0);
  size_t next_change = 0;
  if (env.steering.enabled()) {
    if (script->changes.empty()) {
      script->changes = {{0, e.motion_set().entry(e.motion_set().commands().front()).name}};
    }
    worker.SetCommandFirst(e.motion_set().Find(script->changes.front().command));
    next_change = 1;
  }
  worker.ResetFirst(phase);
  return next_change;
}

// "; the episode ended with a fall at 3.20 s" (or "with its clip"), for the step that ended it.
std::string EpisodeEnding(const sim::StepResult& r, double time) {
  char line[200];
  std::snprintf(line, sizeof line, "; the episode %s at %.2f s",
                r.terminated ? "ended with a fall" : "ended with its clip", time);
  return line;
}

// "; 2 pushes, fell and got up" after random pushes, else "".
std::string PushSummary(const eval::RandomPushes& pushes, const sim::ImitationEnv& e) {
  if (pushes.count() == 0) return "";
  char line[120];
  std::snprintf(line, sizeof line, "; %d push%s%s", pushes.count(), pushes.count() == 1 ? "" : "es",
                e.episode().task_falls > 0 ? ", fell and got up" : "");
  return line;
}

// The simulated motion: a pose per control step from the reset on, and how the episode went.
struct Recording {
  std::vector<character::Pose> frames;
  std::string ending;  // appended to the report line: EpisodeEnding, PushSummary
};

Recording Record(Performance& p, const BakeOptions& o) {
  actor::RolloutWorker worker(p.env, 1, 1, o.seed, "bake");
  worker.SetPolicy(p.policy.snapshot);
  sim::ImitationEnv& e = worker.environment(0);
  size_t next_change = StartEpisode(worker, p.env, &p.script, o.phase);
  Recording r{{p.character->QposToPose(e.data().qpos)}, ""};
  eval::RandomPushes pushes(o.pushes, o.pushes, o.pushes > 0 ? o.push_every : 0, 1 / p.rate, o.seed,
                            p.character->root_body());
  eval::ScriptedPushes scripted(p.script.pushes, *p.character);
  for (int s = 1; s <= p.steps; ++s) {
    const double t = (s - 1) / p.rate;
    if (next_change < p.script.changes.size() && p.script.changes[next_change].at <= t) {
      worker.SetCommandFirst(e.motion_set().Find(p.script.changes[next_change++].command));
    }
    if (pushes.Before(e, s - 1)) {
      std::fprintf(stderr, "bake: push at %.2f s: %.0f N s on the pelvis toward %.0f deg\n", t,
                   pushes.last_impulse(), pushes.last_angle() * 180 / M_PI);
    }
    scripted.Before(e, t);
    const sim::StepResult step = worker.StepFirst(true);
    r.frames.push_back(p.character->QposToPose(e.data().qpos));
    if (step.terminated || step.truncated) {
      r.ending = EpisodeEnding(step, e.time());
      break;
    }
  }
  r.ending += PushSummary(pushes, e);
  return r;
}

// The recorded frames as a one-shot clip named after the reference, resampled to `fps` when given.
character::MotionClip BakedClip(std::vector<character::Pose> frames,
                                const character::MotionClip& reference, double rate, double fps) {
  std::vector<double> durations(frames.size(), 1 / rate);
  character::MotionClip clip(reference.name() + "_baked", false, std::move(durations),
                             std::move(frames));
  if (fps > 0) clip = motion::Resampled(clip, fps);
  return clip;
}

std::string Units(const BakeOptions& o) { return !o.units.empty() ? o.units : "m"; }

// `clip` as BVH text with the bone names, units and up axis `o` asks for.
std::string BvhText(const character::MotionClip& clip, const character::Character& character,
                    const BakeOptions& o) {
  motion::ExportOptions options;
  options.y_up = o.up == "y";
  options.units_per_metre = Units(o) == "cm" ? 100 : 1;
  return motion::FormatBvh(
      motion::ClipToBvh(clip, character, motion::ReadJointMapping(o.naming), options));
}

// Writes the BVH text as `out`: as it is, converted by Blender (FBX), or by Assimp (glTF).
void WriteAnimation(BakeOutput kind, const std::string& text, const std::string& out) {
  if (kind == BakeOutput::kBvh) {
    std::ofstream file(out);
    file << text;
    if (!file) throw std::runtime_error(out + ": cannot write");
  } else if (kind == BakeOutput::kFbx) {
    ConvertWithBlender(text, out);
  } else {
    motion::ExportBvhAsScene(text, out);
  }
}

}  // namespace

void Bake(const BakeOptions& o) {
  const BakeOutput kind = OutputKind(o.out);
  Performance p = Prepare(o);
  Recording recording = Record(p, o);
  const int simulated = static_cast<int>(recording.frames.size());
  const character::MotionClip clip =
      BakedClip(std::move(recording.frames), p.reference, p.rate, o.fps);
  if (kind == BakeOutput::kJson) {  // the project's own clip format: what `motion import` gives
    character::SaveClip(clip, "baked from " + p.policy.checkpoint, o.out);
    std::fprintf(stderr, "bake: %s: %.2f s simulated%s -> %s: %d frames\n",
                 p.policy.checkpoint.c_str(), (simulated - 1) / p.rate, recording.ending.c_str(),
                 o.out.c_str(), clip.num_frames());
    return;
  }
  WriteAnimation(kind, BvhText(clip, *p.character, o), o.out);
  std::fprintf(stderr,
               "bake: %s (policy v%lld): %.2f s simulated at %.0f Hz%s -> %s: %d frames at %.1f "
               "frames/s, %s joint names, %s, %s-up\n",
               p.policy.checkpoint.c_str(), static_cast<long long>(p.policy.version),
               (simulated - 1) / p.rate, p.rate, recording.ending.c_str(), o.out.c_str(),
               clip.num_frames(), (clip.num_frames() - 1) / clip.duration(), o.naming.c_str(),
               Units(o).c_str(), o.up.c_str());
}

}  // namespace ragdoll::exports
