#include "cli/eval_command.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>

#include "actor/command_evaluation.h"
#include "actor/evaluation.h"
#include "actor/push_evaluation.h"
#include "actor/recovery_evaluation.h"
#include "actor/sim/character.h"
#include "actor/sim/motion_io.h"
#include "actor/sim/motion_set.h"
#include "cli/trained_policy.h"
#include "common/config_section.h"

namespace ragdoll::cli {
namespace {

struct EvalOptions {
  std::string target, json_out;
  int episodes = 20;
  uint64_t seed = 12345;
  bool pushes = false;
  actor::PushConfig push;
  actor::PushProtocolConfig protocol;
  actor::RecoveryConfig recovery{0};  // no recovery trials unless asked
  std::string commands;  // a command script file, "random", or empty (no scripted runs)
  actor::CommandEvalConfig command_eval;
};

// Scripted steering runs (--commands), which need a policy trained with a steering task.
actor::CommandEvalResult EvaluateScripts(const TrainedPolicy& policy, EvalOptions& o) {
  const sim::EnvConfig& env = policy.experiment.environment;
  if (!env.steering.enabled()) {
    throw ConfigError("--commands: " + policy.checkpoint +
                      " was not trained with a steering task (environment.steering)");
  }
  auto character = sim::Character::Load(env.character, env.physics_dt());
  o.command_eval.random = o.commands == "random";
  if (!o.command_eval.random) {
    o.command_eval.script =
        actor::ReadCommandScript(o.commands, *sim::LoadMotionSet(env, *character), *character);
  }
  return actor::EvaluateCommands(env, policy.snapshot, o.command_eval, o.seed);
}

// A run folder keeps its latest evaluation, written whole or not at all.
void WriteRunEvaluation(const std::filesystem::path& run, const std::string& json) {
  const auto path = run / "eval.json";
  const auto temporary = std::filesystem::path(path.string() + ".tmp");
  {
    std::ofstream out(temporary);
    out << json << "\n";
    if (!out.flush()) throw std::runtime_error(temporary.string() + ": cannot write");
  }
  std::filesystem::rename(temporary, path);
  std::fprintf(stderr, "wrote %s\n", path.c_str());
}

// A clip that plays once is judged as it is used: the whole of it from its first frame. Episodes
// from random phases (the other figures) start part-way through and are shorter and easier. The
// simulation and the mean action are deterministic, so one episode says it all; beside it, the
// same episode with the reference's PD targets alone.
struct WholeClip {
  actor::EvaluationResult policy, tracking;
};

std::optional<WholeClip> EvaluateWholeClip(const sim::EnvConfig& env, const TrainedPolicy& policy,
                                           uint64_t seed) {
  // Steering and recovery switch clips; a looping clip has no first frame to be judged from.
  if (env.steering.enabled() || env.recovery.enabled() || sim::LoadMotion(env.motion).loop()) {
    return std::nullopt;
  }
  sim::EnvConfig from_start = env;
  from_start.random_start = false;
  from_start.start_phase = 0;
  return WholeClip{actor::Evaluate(from_start, policy.snapshot, 1, seed),
                   actor::EvaluateReferenceTracking(from_start, 1, seed)};
}

nlohmann::json EpisodeJson(const actor::EvaluationResult& r) {
  return {{"normalized_return", r.normalized_return},
          {"episode_length", r.episode_length},
          {"fell", r.fall_rate > 0}};
}

int RunEval(EvalOptions& o) {
  TrainedPolicy policy = LoadTrainedPolicy(o.target);
  const sim::EnvConfig& env = policy.experiment.environment;
  actor::EvaluationResult r = actor::Evaluate(env, policy.snapshot, o.episodes, o.seed);
  const std::optional<WholeClip> whole = EvaluateWholeClip(env, policy, o.seed);
  std::unique_ptr<actor::RobustnessResult> robustness;
  std::unique_ptr<actor::PushProtocolResult> protocol;
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
    protocol = std::make_unique<actor::PushProtocolResult>(
        actor::EvaluatePushProtocol(env, policy.snapshot, o.protocol, o.seed));
    robustness = std::make_unique<actor::RobustnessResult>(
        actor::EvaluatePushes(env, policy.snapshot, o.push, o.seed));
  }
  std::unique_ptr<actor::RecoveryResult> recovery;
  if (o.recovery.trials > 0) {
    recovery = std::make_unique<actor::RecoveryResult>(
        actor::EvaluateRecovery(env, policy.snapshot, o.recovery, o.seed));
  }
  std::unique_ptr<actor::CommandEvalResult> scripted;
  if (!o.commands.empty()) {
    scripted = std::make_unique<actor::CommandEvalResult>(EvaluateScripts(policy, o));
  }
  // Which checkpoint was evaluated goes with the figures (`ragdoll report` shows it).
  nlohmann::json result = nlohmann::json::parse(r.ToJson(robustness.get()));
  if (protocol) result["perturbation"]["protocol"] = nlohmann::json::parse(protocol->ToJson());
  if (recovery) result["recovery"] = nlohmann::json::parse(recovery->ToJson());
  if (scripted) {
    result["commands"] = nlohmann::json::parse(scripted->ToJson());
    result["commands"]["script"] = o.commands;
  }
  if (whole) {
    result["whole_clip"] = EpisodeJson(whole->policy);
    result["whole_clip"]["reference_tracking"] = EpisodeJson(whole->tracking);
  }
  result["checkpoint"] = policy.checkpoint;
  result["policy_version"] = policy.version;
  result["samples"] = policy.samples;
  const std::string json = result.dump(2);
  std::cout << json << "\n";
  std::fprintf(stderr,
               "%s (policy v%lld, %lld samples): normalised return %.3f, length %.1f steps, "
               "fall rate %.2f over %d episodes\n",
               policy.checkpoint.c_str(), static_cast<long long>(policy.version),
               static_cast<long long>(policy.samples), r.normalized_return, r.episode_length,
               r.fall_rate, r.episodes);
  if (whole) {
    auto line = [](const actor::EvaluationResult& e) {
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
  if (std::filesystem::is_directory(o.target)) WriteRunEvaluation(o.target, json);
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
