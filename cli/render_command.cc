#include "cli/render_command.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>

#include "actor/rollout.h"
#include "character/motion_io.h"
#include "common/config_section.h"
#include "eval/command_evaluation.h"
#include "eval/scripted_pushes.h"
#include "render/renderer.h"
#include "render/video.h"
#include "run/trained_policy.h"
#include "sim/steering_task.h"

namespace ragdoll::cli {
namespace {

struct RenderOptions {
  std::string target, clip, out;
  double seconds = 0;  // 0: one clip cycle (at least 3 s) without a policy, 10 s with one
  double phase = 0;
  double time = -1;  // .png: the moment to show (default: the middle)
  std::string ghost = "side";
  std::string commands;  // steering runs: a command script file, or "random"
  render::View view;
  uint64_t seed = 1;
};

// Runs this command again under xvfb-run when there is no display; returns only if it could not.
void EnsureDisplay(int argc, char** argv) {
  const char* display = std::getenv("DISPLAY");
  if ((display && *display) || std::getenv("RAGDOLL_UNDER_XVFB")) return;
  setenv("RAGDOLL_UNDER_XVFB", "1", 1);
  char self[4096];
  ssize_t n = readlink("/proc/self/exe", self, sizeof(self) - 1);
  if (n <= 0) return;
  self[n] = '\0';
  std::vector<std::string> args = {"xvfb-run", "-a", "-s", "-screen 0 1920x1080x24", self};
  for (int i = 1; i < argc; ++i) args.push_back(argv[i]);
  std::vector<char*> c;
  for (auto& a : args) c.push_back(a.data());
  c.push_back(nullptr);
  execvp("xvfb-run", c.data());
  std::fprintf(stderr, "ragdoll render: no DISPLAY and cannot run xvfb-run (install xvfb)\n");
}

// How long a push stays in the caption after it has ended, s.
constexpr double kPushCaptionSeconds = 1.0;

std::string Caption(const std::string& clip, double t, const std::string& policy, double normalized,
                    bool fell) {
  char text[256];
  std::snprintf(text, sizeof(text), "clip %s\ntime %.2f s\n%s%s", clip.c_str(), t, policy.c_str(),
                fell ? "\nfell: restarted" : "");
  std::string caption = text;
  if (normalized >= 0) {
    std::snprintf(text, sizeof(text), "\nnormalised return %.3f", normalized);
    caption += text;
  }
  return caption;
}

// The command, and how well the character follows it.
std::string SteeringCaption(const sim::ImitationEnv& e) {
  const sim::SteeringTask& steering = sim::Steering(e);
  char text[256];
  const sim::MotionSetEntry& reference = e.motion_set().entry(e.reference_entry());
  if (reference.get_up) {
    // Travel is not tracked while a get-up plays: what plays instead.
    std::snprintf(text, sizeof(text), "\ncommand %s\nplaying %s",
                  e.motion_set().entry(steering.command_entry()).name.c_str(),
                  reference.name.c_str());
    return text;
  }
  const character::Vec3 v = steering.TravelVelocity();
  // What the task holds the command back for: a stand after a get-up, a catch step.
  std::string held;
  if (steering.standing_after_get_up()) held = " (standing after the get-up)";
  if (steering.catching() >= 0) {
    held += ", catch step: " + e.motion_set().entry(steering.catching()).name;
  }
  std::snprintf(text, sizeof(text), "\ncommand %s%s\nspeed %.2f m/s, heading error %.0f deg",
                e.motion_set().entry(steering.command_entry()).name.c_str(), held.c_str(),
                std::hypot(v[0], v[1]), steering.HeadingError(e) * 180 / M_PI);
  return text;
}

// The environment to render: the run's (its clip replaced by --clip), or without a run the
// default character following --clip.
sim::EnvConfig RenderEnvironment(const RenderOptions& o, const run::TrainedPolicy* policy) {
  sim::EnvConfig env;
  if (policy) {
    env = policy->experiment.environment;
    if (!o.clip.empty()) env.motion = o.clip;
    if (!o.commands.empty() && !env.steering.enabled()) {
      throw ConfigError("render --commands: " + policy->checkpoint +
                        " was not trained with a steering task (environment.steering)");
    }
  } else {
    if (!o.commands.empty()) throw ConfigError("render --commands: give a steering run");
    if (o.clip.empty()) throw ConfigError("render: give a run (or checkpoint), --clip, or both");
    env.motion = o.clip;
    env.character = character::DefaultCharacterPath();
  }
  return env;
}

// Draws frames into the video, counting them; a still keeps only the step it shows.
struct FrameWriter {
  render::Renderer& renderer;
  render::VideoWriter& video;
  int still_step;
  int drawn = 0;

  void Emit(int step, const mjData& sim, const mjData* reference, const std::string& c) {
    if (video.single_frame() && step != still_step) return;
    renderer.Draw(sim, reference, c);
    video.Write(renderer.pixels());
    ++drawn;
  }
};

// The reference alone: the clip's poses on the character, no physics.
void RenderReference(const character::Character& character, const character::MotionClip& clip,
                     double fps, int steps, FrameWriter& frames) {
  character::DataPtr d = character.MakeData();
  for (int s = 0; s <= steps; ++s) {
    const double t = s / fps;
    character.PoseToQpos(clip.Sample(t), d->qpos);
    mj_kinematics(character.model(), d.get());
    frames.Emit(s, *d, nullptr, Caption(clip.name(), t, "reference only", -1, false));
  }
}

// A steered path's first command: from `script`, which random commands or the first command
// throughout fill when it has none. Returns the index of the next change.
size_t StartCommands(const RenderOptions& o, const sim::EnvConfig& env, double seconds,
                     actor::RolloutWorker& worker, eval::CommandScript& script) {
  sim::ImitationEnv& e = worker.environment(0);
  const sim::MotionSet& motions = e.motion_set();
  if (o.commands == "random") {
    script = eval::RandomCommandScript(motions, seconds, env.steering.command_interval_min,
                                       env.steering.command_interval_max, o.seed);
  } else if (script.changes.empty()) {
    script.changes = {{0, motions.entry(motions.commands().front()).name}};
  }
  worker.SetCommandFirst(motions.Find(script.changes.front().command));
  return 1;
}

// A policy frame's caption at run time `t`: clip, time, the return so far, then the command
// (steering) and the push under way.
std::string PolicyCaption(const sim::ImitationEnv& e, const std::string& label, bool fell,
                          bool steering, const eval::ScriptedPushes& pushes, double t) {
  const auto& ep = e.episode();
  const double normalized =
      ep.length > 0 ? ep.episode_return / (e.spec().max_reward_per_step * ep.length) : 1.0;
  std::string caption = Caption(e.clip().name(), e.time(), label, normalized, fell);
  if (steering) caption += SteeringCaption(e);
  const std::string push = pushes.Describe(t, kPushCaptionSeconds);
  if (!push.empty()) caption += "\n" + push;
  return caption;
}

// The policy's episode beside its reference, restarted where it ends (a fall or the time limit).
void RenderPolicy(const RenderOptions& o, const run::TrainedPolicy& policy, sim::EnvConfig& env,
                  const character::Character& character, eval::CommandScript& script,
                  double seconds, int steps, FrameWriter& frames) {
  const double fps = env.control_frequency;
  const bool steering = env.steering.enabled();
  // A steered path is one episode: no time limit restarts it half-way.
  if (steering) env.max_episode_steps = std::max(env.max_episode_steps, steps + 1);
  actor::RolloutWorker worker(env, 1, 1, o.seed, "render");
  worker.SetPolicy(policy.snapshot);
  sim::ImitationEnv& e = worker.environment(0);
  size_t next_change = 0;
  if (steering) next_change = StartCommands(o, env, seconds, worker, script);
  worker.ResetFirst(o.phase);
  eval::ScriptedPushes pushes(script.pushes, character);
  character::DataPtr reference = character.MakeData();
  std::vector<double> qvel(character.model()->nv);
  const std::string label = "policy v" + std::to_string(policy.version);
  bool fell = false;
  auto draw = [&](int s) {
    e.ReferenceState(e.time(), reference->qpos, qvel.data());
    mj_kinematics(character.model(), reference.get());
    const std::string caption = PolicyCaption(e, label, fell, steering, pushes, s / fps);
    frames.Emit(s, e.data(), o.ghost == "none" ? nullptr : reference.get(), caption);
  };
  draw(0);
  for (int s = 1; s <= steps; ++s) {
    if (next_change < script.changes.size() && script.changes[next_change].at <= (s - 1) / fps) {
      worker.SetCommandFirst(e.motion_set().Find(script.changes[next_change++].command));
    }
    pushes.Before(e, (s - 1) / fps);
    sim::StepResult r = worker.StepFirst(true);
    if (r.terminated || r.truncated) {
      fell = r.terminated;
      std::fprintf(stderr, "render: episode %s at %.2f s, normalised return %.3f\n",
                   r.terminated ? "ended (fell)" : "reached its time limit", e.time(),
                   e.episode().normalized_return);
      worker.ResetFirst(e.phase());
    }
    draw(s);
  }
}

int Render(const RenderOptions& o) {
  using Clock = std::chrono::steady_clock;
  const bool with_policy = !o.target.empty();
  std::unique_ptr<run::TrainedPolicy> policy;
  if (with_policy) {
    policy = std::make_unique<run::TrainedPolicy>(run::LoadTrainedPolicy(o.target));
  }
  sim::EnvConfig env = RenderEnvironment(o, policy.get());
  auto clip = character::LoadMotion(env.motion);
  auto character = character::Character::Load(env.character, env.physics_dt());
  const double fps = env.control_frequency;
  // Steering: the script's commands (or the first command throughout) instead of training's
  // random ones; a script file sets the length.
  eval::CommandScript script;
  if (!o.commands.empty() && o.commands != "random") {
    script = eval::ReadCommandScript(o.commands, *sim::LoadMotionSet(env, *character), *character);
  }
  const double seconds = o.seconds > 0         ? o.seconds
                         : script.duration > 0 ? script.duration
                         : with_policy         ? 10.0
                                               : std::max(3.0, clip.duration());
  const int steps = std::max(1, static_cast<int>(std::lround(seconds * fps)));

  render::View view = o.view;
  view.ghost_offset = o.ghost == "side" ? 1.0 : 0.0;
  render::Renderer renderer(character->model(), view);
  render::VideoWriter video(o.out, view.width, view.height, fps);
  // A still shows one moment: the middle of the requested span unless --time says otherwise.
  const int still_step = o.time >= 0 ? static_cast<int>(std::lround(o.time * fps)) : steps / 2;
  const auto start = Clock::now();
  FrameWriter frames{renderer, video, still_step};

  if (!with_policy) {
    RenderReference(*character, clip, fps, steps, frames);
  } else {
    RenderPolicy(o, *policy, env, *character, script, seconds, steps, frames);
  }
  video.Close();
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  const int drawn = frames.drawn;
  std::fprintf(stderr, "render: %s: %d frame%s of %dx%d in %.1f s (%.1f frames/s)\n", o.out.c_str(),
               drawn, drawn == 1 ? "" : "s", view.width, view.height, elapsed,
               drawn / std::max(elapsed, 1e-9));
  return 0;
}

}  // namespace

std::function<int()> AddRenderCommand(CLI::App& app, int argc, char** argv) {
  auto o = std::make_shared<RenderOptions>();
  auto* cmd = app.add_subcommand(
      "render", "video of a trained ragdoll beside its reference clip (or the clip alone)");
  cmd->add_option("run_or_checkpoint", o->target, "runs/<id> or a checkpoint (omit: clip only)");
  cmd->add_option("--clip", o->clip, "clip to follow (default: the run's)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--out", o->out, "FILE.mp4, FILE.gif or FILE.png")->required();
  cmd->add_option("--seconds", o->seconds, "length (default: 10 s; clip only: one cycle)");
  cmd->add_option("--phase", o->phase, "clip phase to start at (0..1)")->capture_default_str();
  cmd->add_option("--time", o->time, ".png: the moment to show, seconds (default: the middle)");
  cmd->add_option("--ghost", o->ghost, "reference drawn beside (side), overlaid, or none")
      ->check(CLI::IsMember({"side", "overlay", "none"}))
      ->capture_default_str();
  cmd->add_option("--width", o->view.width)->capture_default_str()->check(CLI::Range(64, 3840));
  cmd->add_option("--height", o->view.height)->capture_default_str()->check(CLI::Range(64, 2160));
  cmd->add_option("--distance", o->view.distance, "camera distance, m")->capture_default_str();
  cmd->add_option("--azimuth", o->view.azimuth, "camera azimuth, degrees")->capture_default_str();
  cmd->add_option("--elevation", o->view.elevation, "camera elevation, degrees")
      ->capture_default_str();
  cmd->add_option("--commands", o->commands,
                  "steering runs: a command script (YAML, as `eval --commands`) or 'random' "
                  "(default: the first command throughout)");
  cmd->add_option("--seed", o->seed)->capture_default_str();
  return [=]() -> int {
    if (!*cmd) return -1;
    EnsureDisplay(argc, argv);
    return Render(*o);
  };
}

}  // namespace ragdoll::cli
