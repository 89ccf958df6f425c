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
#include <signal.h>
#include <unistd.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "actor/command_evaluation.h"
#include "actor/evaluation.h"
#include "actor/rollout.h"
#include "broker/broker.h"
#include "cli/experiment.h"
#include "cli/export_command.h"
#include "cli/keygen_command.h"
#include "cli/launcher.h"
#include "cli/motion_commands.h"
#include "cli/play_command.h"
#include "cli/render_command.h"
#include "cli/report_command.h"
#include "cli/trained_policy.h"
#include "cli/verify_command.h"
#include "common/config_section.h"
#include "learner/learner.h"
#include "learner/learner_process.h"

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

std::string Hostname() {
  char name[256] = "host";
  gethostname(name, sizeof(name) - 1);
  return name;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace ragdoll;
  CLI::App app("ragdoll: train physics-simulated characters to imitate animation clips.");
  app.require_subcommand(1);

  cli::TrainOptions train;
  auto* train_cmd = app.add_subcommand("train", "broker, learner and actors on this machine");
  train_cmd->add_option("config", train.config, "experiment YAML (configs/*.yaml)")->required();
  train_cmd->add_option("--run-id", train.run_id, "run name (default: config name and time)");
  train_cmd->add_option("--runs-dir", train.runs_dir, "where run folders go")
      ->capture_default_str();
  train_cmd->add_flag("--resume", train.resume, "continue the run --run-id from its checkpoint");
  train_cmd->add_option("--init-from", train.init_from, "start from another run's weights");
  train_cmd->add_option("--actors", train.actors, "actor processes (default: cores - 1)");
  train_cmd->add_option("--port-base", train.port_base, "use ports PORT_BASE..PORT_BASE+4");
  train_cmd->add_option("--replicas", train.replicas,
                        "learner replicas (default: the config's learner.replicas)");
  train_cmd->add_option("--keys", train.keys,
                        "CURVE keys folder (`ragdoll keygen`; default: security.keys)");
  train_cmd->add_flag("--insecure", train.insecure,
                      "let the broker listen beyond loopback without keys");

  // The distributed roles also read their options from RAGDOLL_* environment variables (for
  // containers); a command-line option wins over its variable.
  std::string config, run_id, run_dir, init_from, broker_host, keys, key, bind;
  int port_base = 0, index = 0, metrics_port = -1, replicas = 0;
  bool resume = false, insecure = false;
  auto* broker_cmd = app.add_subcommand("broker", "run the broker");
  auto* learner_cmd = app.add_subcommand("learner", "run the learner");
  auto* actor_cmd = app.add_subcommand("actor", "run one actor process");
  for (auto* cmd : {broker_cmd, learner_cmd, actor_cmd}) {
    cmd->add_option("config", config, "experiment YAML")->required()->envname("RAGDOLL_CONFIG");
    cmd->add_option("--run-id", run_id, "run name, shared by every role")
        ->required()
        ->envname("RAGDOLL_RUN_ID");
    cmd->add_option("--port-base", port_base, "use ports PORT_BASE..PORT_BASE+4")
        ->envname("RAGDOLL_PORT_BASE");
    cmd->add_option("--metrics-port", metrics_port,
                    "Prometheus endpoint port (default: the config's metrics section)")
        ->envname("RAGDOLL_METRICS_PORT");
    cmd->add_option("--keys", keys, "CURVE keys folder (default: the config's security.keys)")
        ->envname("RAGDOLL_KEYS");
    cmd->add_option("--key", key,
                    "this process's secret certificate (default: KEYS/ROLE.key_secret)")
        ->envname("RAGDOLL_KEY");
  }
  broker_cmd
      ->add_option("--bind", bind, "interface to listen on (default: the config's broker.bind)")
      ->envname("RAGDOLL_BROKER_BIND");
  broker_cmd->add_flag("--insecure", insecure, "listen beyond loopback without keys")
      ->envname("RAGDOLL_INSECURE");
  for (auto* cmd : {learner_cmd, actor_cmd}) {
    cmd->add_option("--broker-host", broker_host, "where the broker is (default: broker.host)")
        ->envname("RAGDOLL_BROKER_HOST");
  }
  learner_cmd->add_option("--run-dir", run_dir, "run folder (default: runs/RUN_ID)")
      ->envname("RAGDOLL_RUN_DIR");
  learner_cmd->add_flag("--resume", resume, "continue from the newest checkpoint in the run")
      ->envname("RAGDOLL_RESUME");
  learner_cmd->add_option("--init-from", init_from, "start from another run's weights");
  learner_cmd
      ->add_option("--replicas", replicas,
                   "learner replicas in the group (default: the "
                   "config's learner.replicas)")
      ->envname("RAGDOLL_LEARNER_REPLICAS");
  learner_cmd
      ->add_option("--index", index, "replica number on this host, for its id and metrics port")
      ->envname("RAGDOLL_LEARNER_INDEX");
  actor_cmd->add_option("--index", index, "actor number, for its id, seed and metrics port")
      ->envname("RAGDOLL_ACTOR_INDEX");

  std::string eval_target, json_out;
  int episodes = 20;
  uint64_t eval_seed = 12345;
  auto* eval_cmd = app.add_subcommand("eval", "evaluate a trained policy deterministically");
  eval_cmd->add_option("run_or_checkpoint", eval_target, "runs/<id> or a checkpoint file")
      ->required();
  eval_cmd->add_option("--episodes", episodes, "episodes to run")->capture_default_str();
  eval_cmd->add_option("--seed", eval_seed, "seed of the start phases")->capture_default_str();
  eval_cmd->add_option("--json", json_out, "also write the result to this file");
  bool pushes = false;
  actor::PushConfig push;
  eval_cmd->add_flag("--pushes", pushes, "also run push trials (robustness)");
  eval_cmd->add_option("--push-impulses", push.impulses, "impulses to try, N s")
      ->delimiter(',')
      ->capture_default_str();
  eval_cmd->add_option("--push-trials", push.trials, "trials per impulse")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  eval_cmd->add_option("--push-body", push.body, "body pushed")->capture_default_str();
  eval_cmd->add_option("--push-duration", push.duration, "seconds the push lasts")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  eval_cmd
      ->add_option("--push-direction", push.direction,
                   "random, or forward/backward/left/right of the heading")
      ->capture_default_str();

  std::string commands;
  actor::CommandEvalConfig command_eval;
  eval_cmd->add_option("--commands", commands,
                       "steering runs: play a command script (FILE) or 'random' scripts, and "
                       "score speed and heading tracking, falls and transitions");
  eval_cmd->add_option("--command-runs", command_eval.runs, "scripted runs (--commands)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  eval_cmd
      ->add_option("--command-seconds", command_eval.duration,
                   "length of each random script, s (--commands random)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);

  std::function<int()> motion = cli::AddMotionCommands(app);
  std::function<int()> render = cli::AddRenderCommand(app, argc, argv);
  std::function<int()> play = cli::AddPlayCommand(app, g_stop);
  std::function<int()> report = cli::AddReportCommand(app);
  std::function<int()> keygen = cli::AddKeygenCommand(app);
  std::function<int()> verify = cli::AddVerifyCommand(app);
  std::function<int()> exporter = cli::AddExportCommand(app);
  CLI11_PARSE(app, argc, argv);
  InstallSignalHandlers();
  try {
    if (*train_cmd) return cli::RunTrain(train, g_stop);
    if (int code = motion(); code >= 0) return code;
    if (int code = render(); code >= 0) return code;
    if (int code = play(); code >= 0) return code;
    if (int code = report(); code >= 0) return code;
    if (int code = keygen(); code >= 0) return code;
    if (int code = verify(); code >= 0) return code;
    if (int code = exporter(); code >= 0) return code;

    if (*eval_cmd) {
      cli::TrainedPolicy policy = cli::LoadTrainedPolicy(eval_target);
      sim::EnvConfig env = policy.experiment.environment;
      actor::EvaluationResult r = actor::Evaluate(env, policy.snapshot, episodes, eval_seed);
      std::unique_ptr<actor::RobustnessResult> robustness;
      if (pushes) {
        robustness = std::make_unique<actor::RobustnessResult>(
            actor::EvaluatePushes(env, policy.snapshot, push, eval_seed));
      }
      std::unique_ptr<actor::CommandEvalResult> scripted;
      if (!commands.empty()) {
        if (!env.steering.enabled()) {
          throw ConfigError("--commands: " + policy.checkpoint +
                            " was not trained with a steering task (environment.steering)");
        }
        auto character = sim::Character::Load(env.character, env.physics_dt());
        command_eval.random = commands == "random";
        if (!command_eval.random) {
          command_eval.script =
              actor::ReadCommandScript(commands, *sim::LoadMotionSet(env, *character));
        }
        scripted = std::make_unique<actor::CommandEvalResult>(
            actor::EvaluateCommands(env, policy.snapshot, command_eval, eval_seed));
      }
      // Which checkpoint was evaluated goes with the figures (`ragdoll report` shows it).
      nlohmann::json result = nlohmann::json::parse(r.ToJson(robustness.get()));
      if (scripted) {
        result["commands"] = nlohmann::json::parse(scripted->ToJson());
        result["commands"]["script"] = commands;
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
      if (robustness) std::fprintf(stderr, "%s", robustness->ToTable().c_str());
      if (scripted) std::fprintf(stderr, "%s", scripted->ToTable().c_str());
      if (!json_out.empty()) std::ofstream(json_out) << json << "\n";
      // A run folder keeps its latest evaluation, written whole or not at all.
      if (std::filesystem::is_directory(eval_target)) {
        const auto path = std::filesystem::path(eval_target) / "eval.json";
        const auto temporary = std::filesystem::path(path.string() + ".tmp");
        {
          std::ofstream out(temporary);
          out << json << "\n";
          if (!out.flush()) throw std::runtime_error(temporary.string() + ": cannot write");
        }
        std::filesystem::rename(temporary, path);
        std::fprintf(stderr, "wrote %s\n", path.c_str());
      }
      return 0;
    }

    cli::Experiment e = cli::ReadExperiment(config, port_base);
    if (!broker_host.empty()) e.broker.endpoints.host = broker_host;
    if (!bind.empty()) e.broker.endpoints.bind = bind;
    if (!keys.empty()) e.keys_dir = keys;
    const char* role = *broker_cmd ? "broker" : *learner_cmd ? "learner" : "actor";
    e.broker.endpoints.curve = LoadCurve(e.keys_dir, role, key);
    e.broker.keys_dir = e.keys_dir;
    // The metrics port of this role: the option, else the config's (or none when disabled).
    auto metrics_port_of = [&](int configured) {
      if (metrics_port >= 0) return metrics_port;
      return e.metrics.enabled ? configured : -1;
    };
    if (*broker_cmd) {
      CheckTransportSecurity(e.broker.endpoints, insecure);
      MetricsEndpoint metrics("broker", e.metrics.bind, metrics_port_of(e.metrics.broker_port),
                              run_id);
      zmq::context_t context(1);
      broker::Broker b(context, e.broker, run_id, &metrics);
      std::fprintf(stderr, "broker: listening on %s (actors) and %s (learner), %s\n",
                   e.broker.endpoints.Bind(e.broker.endpoints.trajectory_port).c_str(),
                   e.broker.endpoints.Bind(e.broker.endpoints.learner_port).c_str(),
                   e.broker.endpoints.curve.enabled() ? "CURVE"
                   : IsLoopback(e.broker.endpoints.bind)
                       ? "plaintext (loopback only)"
                       : "PLAINTEXT on a network (--insecure): anyone reaching it can train or "
                         "read the policy");
      b.Run(g_stop);
      return 0;
    }
    if (*actor_cmd) {
      actor::ActorConfig a = e.actor;
      a.run_id = run_id;
      a.actor_id = Hostname() + "-actor-" + std::to_string(index);
      a.seed = e.actor.seed * 1000003ull + static_cast<uint64_t>(index) * 7919ull;
      a.metrics_bind = e.metrics.bind;
      a.metrics_port = metrics_port_of(e.metrics.actor_port + index);
      return actor::RunActor(e.environment, a, e.broker.endpoints, g_stop);
    }
    if (*learner_cmd) {
      const sim::EnvSpec spec = sim::MakeEnvSpec(
          e.environment,
          *sim::Character::Load(e.environment.character, e.environment.physics_dt()));
      learner::LearnerProcessConfig l;
      l.run_id = run_id;
      l.run_dir = run_dir.empty() ? "runs/" + run_id : run_dir;
      l.label = e.name;
      l.config_text = e.text;
      l.observation_size = spec.observation_size;
      l.action_size = spec.action_size;
      l.figure_names = spec.figure_names;
      l.reward_terms = spec.reward_terms;
      l.resume = resume;
      l.init_from = init_from;
      l.metrics_bind = e.metrics.bind;
      l.metrics_port = metrics_port_of(index == 0 ? e.metrics.learner_port
                                                  : e.metrics.learner_replica_port + index);
      l.replica = e.learner;
      if (replicas > 0) l.replica.replicas = replicas;
      l.replica_id = Hostname() + "-learner-" + std::to_string(index);
      return learner::RunLearner(e.trainer, l, e.broker.endpoints, g_stop);
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
