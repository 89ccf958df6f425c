#include "cli/eval_command.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>

#include "character/character.h"
#include "character/motion_io.h"
#include "common/config_section.h"
#include "eval/command_evaluation.h"
#include "eval/eval_file.h"
#include "eval/evaluation.h"
#include "eval/push_evaluation.h"
#include "eval/recovery_evaluation.h"
#include "run/trained_policy.h"
#include "sim/motion_set.h"

namespace ragdoll::cli {
namespace {

struct EvalOptions {
  std::string target, json_out;
  int episodes = 20;
  uint64_t seed = 12345;
  bool pushes = false;
  eval::PushConfig push;
  eval::PushProtocolConfig protocol;
  eval::RecoveryConfig recovery{0};  // no recovery trials unless asked
  std::string commands;              // a command script file, "random", or empty (no scripted runs)
  eval::CommandEvalConfig command_eval;
};

// Scripted steering runs (--commands), which need a policy trained with a steering task.
eval::CommandEvalResult EvaluateScripts(const run::TrainedPolicy& policy, EvalOptions& o) {
  const sim::EnvConfig& env = policy.experiment.environment;
  if (!env.steering.enabled()) {
    throw ConfigError("--commands: " + policy.checkpoint +
                      " was not trained with a steering task (environment.steering)");
  }
  auto character = character::Character::Load(env.character, env.physics_dt());
  o.command_eval.random = o.commands == "random";
  if (!o.command_eval.random) {
    o.command_eval.script =
        eval::ReadCommandScript(o.commands, *sim::LoadMotionSet(env, *character), *character);
  }
  return eval::EvaluateCommands(env, policy.snapshot, o.command_eval, o.seed);
}

// A clip that plays once is judged as it is used: the whole of it from its first frame. Episodes
// from random phases (the other figures) start part-way through and are shorter and easier. The
// simulation and the mean action are deterministic, so one episode says it all; beside it, the
// same episode with the reference's PD targets alone.
struct WholeClip {
  eval::EvaluationResult policy, tracking;
};

std::optional<WholeClip> EvaluateWholeClip(const sim::EnvConfig& env,
                                           const run::TrainedPolicy& policy, uint64_t seed) {
  // Steering and recovery switch clips; a looping clip has no first frame to be judged from.
  if (env.steering.enabled() || env.recovery.enabled() ||
      character::LoadMotion(env.motion).loop()) {
    return std::nullopt;
  }
  sim::EnvConfig from_start = env;
  from_start.random_start = false;
  from_start.start_phase = 0;
  return WholeClip{eval::Evaluate(from_start, policy.snapshot, 1, seed),
                   eval::EvaluateReferenceTracking(from_start, 1, seed)};
}

eval::EpisodeFigures FiguresOf(const eval::EvaluationResult& r) {
  return {r.normalized_return, r.episode_length, r.fall_rate > 0};
}

int RunEval(EvalOptions& o) {
  run::TrainedPolicy policy = run::LoadTrainedPolicy(o.target);
  const sim::EnvConfig& env = policy.experiment.environment;
  eval::EvaluationResult r = eval::Evaluate(env, policy.snapshot, o.episodes, o.seed);
  const std::optional<WholeClip> whole = EvaluateWholeClip(env, policy, o.seed);
  std::unique_ptr<eval::RobustnessResult> robustness;
  std::unique_ptr<eval::PushProtocolResult> protocol;
  if (o.pushes) {
    o.protocol.body = o.push.body;
    o.protocol.trials = o.push.trials;
    // A steered character is pushed while it walks, unless told otherwise.
    if (o.push.command.empty() &&
        std::any_of(env.steering.motions.begin(), env.steering.motions.end(),
                    [](const sim::MotionSetItem& m) { return m.name == "walk"; })) {
      o.push.command = "walk";
    }
    o.protocol.command = o.push.command;
    protocol = std::make_unique<eval::PushProtocolResult>(
        eval::EvaluatePushProtocol(env, policy.snapshot, o.protocol, o.seed));
    robustness = std::make_unique<eval::RobustnessResult>(
        eval::EvaluatePushes(env, policy.snapshot, o.push, o.seed));
  }
  std::unique_ptr<eval::RecoveryResult> recovery;
  if (o.recovery.trials > 0) {
    recovery = std::make_unique<eval::RecoveryResult>(
        eval::EvaluateRecovery(env, policy.snapshot, o.recovery, o.seed));
  }
  std::unique_ptr<eval::CommandEvalResult> scripted;
  if (!o.commands.empty()) {
    scripted = std::make_unique<eval::CommandEvalResult>(EvaluateScripts(policy, o));
  }
  eval::EvaluationSections sections;
  sections.episodes = r.ToJson(robustness.get());
  if (protocol) sections.push_protocol = protocol->ToJson();
  if (recovery) sections.recovery = recovery->ToJson();
  if (scripted) {
    sections.commands = scripted->ToJson();
    sections.command_script = o.commands;
  }
  if (whole) sections.whole_clip = {FiguresOf(whole->policy), FiguresOf(whole->tracking)};
  sections.checkpoint = policy.checkpoint;
  sections.policy_version = policy.version;
  sections.samples = policy.samples;
  const std::string json = eval::ComposeEvaluationJson(sections);
  std::cout << json << "\n";
  std::fprintf(stderr,
               "%s (policy v%lld, %lld samples): normalised return %.3f, length %.1f steps, "
               "fall rate %.2f over %d episodes\n",
               policy.checkpoint.c_str(), static_cast<long long>(policy.version),
               static_cast<long long>(policy.samples), r.normalized_return, r.episode_length,
               r.fall_rate, r.episodes);
  if (whole) {
    auto line = [](const eval::EvaluationResult& e) {
      char text[120];
      std::snprintf(text, sizeof text, "normalised return %.3f over %.0f steps, %s",
                    e.normalized_return, e.episode_length, e.fall_rate > 0 ? "fell" : "no fall");
      return std::string(text);
    };
    std::fprintf(stderr, "the clip plays once: from its first frame, %s (PD targets alone: %s)\n",
                 line(whole->policy).c_str(), line(whole->tracking).c_str());
  }
  if (protocol) std::fprintf(stderr, "%s", protocol->ToTable().c_str());
  if (robustness) std::fprintf(stderr, "%s", robustness->ToTable().c_str());
  if (recovery) std::fprintf(stderr, "%s", recovery->ToTable().c_str());
  if (scripted) std::fprintf(stderr, "%s", scripted->ToTable().c_str());
  if (!o.json_out.empty()) std::ofstream(o.json_out) << json << "\n";
  if (std::filesystem::is_directory(o.target)) {
    eval::WriteEvaluationFile(o.target, json);
    std::fprintf(stderr, "wrote %s\n",
                 (std::filesystem::path(o.target) / eval::kEvaluationFile).c_str());
  }
  return 0;
}

}  // namespace

std::function<int()> AddEvalCommand(CLI::App& app) {
  auto o = std::make_shared<EvalOptions>();
  auto* cmd = app.add_subcommand("eval", "evaluate a trained policy deterministically");
  cmd->add_option("run_or_checkpoint", o->target, "runs/<id> or a checkpoint file")->required();
  cmd->add_option("--episodes", o->episodes, "episodes to run")->capture_default_str();
  cmd->add_option("--seed", o->seed, "seed of the start phases")->capture_default_str();
  cmd->add_option("--json", o->json_out, "also write the result to this file");
  cmd->add_flag("--pushes", o->pushes,
                "also run push trials (robustness): DeepMimic's protocol (0.2 s on the pelvis "
                "toward each side, the largest impulse survived in 90 % of trials by bisection) "
                "and a sweep of given impulses");
  cmd->add_option("--push-resolution", o->protocol.resolution,
                  "bisection stops at this interval, N s")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--push-max", o->protocol.max_impulse, "bisection searches up to this, N s")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--push-impulses", o->push.impulses, "impulses of the sweep, N s")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--push-trials", o->push.trials, "trials per impulse")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--push-body", o->push.body, "body pushed")->capture_default_str();
  cmd->add_option("--push-command", o->push.command,
                  "steering runs: the command held through the push trials (default: walk, "
                  "where the motion set has one)");
  cmd->add_option("--push-duration", o->push.duration, "seconds a push of the sweep lasts")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--push-direction", o->push.direction,
                  "of the sweep: random, or forward/backward/left/right of the heading")
      ->capture_default_str();
  cmd->add_option("--recovery", o->recovery.trials,
                  "also drop the character into N random settled falls (front, back, sides) and "
                  "report the share standing within 5 s and 10 s and the median time")
      ->check(CLI::Range(0, 100000));
  cmd->add_option("--recovery-seconds", o->recovery.seconds, "watched per recovery trial, s")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--recovery-hold", o->recovery.hold,
                  "s the character must keep standing for a recovery trial to count it up")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--commands", o->commands,
                  "steering runs: play a command script (FILE) or 'random' scripts, and "
                  "score speed and heading tracking, falls and transitions");
  cmd->add_option("--command-runs", o->command_eval.runs, "scripted runs (--commands)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--command-seconds", o->command_eval.duration,
                  "length of each random script, s (--commands random)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--command-push-interval", o->command_eval.push_interval,
                  "push the pelvis every S seconds of a scripted run (0: never), toward a random "
                  "direction for 0.2 s (--commands)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--command-push-max", o->command_eval.push_max,
                  "largest impulse of those pushes, N s; each is drawn from [0, this]")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  return [cmd, o]() -> int {
    if (!*cmd) return -1;
    return RunEval(*o);
  };
}

}  // namespace ragdoll::cli
