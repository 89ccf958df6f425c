#include "cli/role_commands.h"

#include <unistd.h>

#include <cstdio>
#include <memory>
#include <string>

#include "actor/actor_process.h"
#include "broker/broker.h"
#include "common/endpoints.h"
#include "common/keys.h"
#include "common/metrics.h"
#include "learner/learner_process.h"
#include "run/experiment.h"
#include "sim/imitation_env.h"

namespace ragdoll::cli {
namespace {

struct RoleOptions {
  std::string config, run_id, run_dir, init_from, broker_host, keys, key, bind;
  int port_base = 0, index = 0, metrics_port = -1, replicas = 0;
  bool resume = false, insecure = false;
};

std::string Hostname() {
  char name[256] = "host";
  gethostname(name, sizeof(name) - 1);
  return name;
}

// The experiment as this role runs it: the config with the command line's overrides and the
// role's CURVE certificate.
run::Experiment ReadRoleExperiment(const RoleOptions& o, const char* role) {
  run::Experiment e = run::ReadExperiment(o.config, o.port_base);
  if (!o.broker_host.empty()) e.broker.endpoints.host = o.broker_host;
  if (!o.bind.empty()) e.broker.endpoints.bind = o.bind;
  if (!o.keys.empty()) e.keys_dir = o.keys;
  e.broker.endpoints.curve = LoadCurve(e.keys_dir, role, o.key);
  e.metrics.bind = ResolveMetricsBind(e.metrics, e.broker.endpoints.host, e.broker.endpoints.bind);
  e.broker.keys_dir = e.keys_dir;
  return e;
}

// The metrics port of this role: the option, else the config's (or none when disabled).
int MetricsPort(const RoleOptions& o, const run::Experiment& e, int configured) {
  if (o.metrics_port >= 0) return o.metrics_port;
  return e.metrics.enabled ? configured : -1;
}

int RunBrokerRole(const RoleOptions& o, const run::Experiment& e, const std::atomic<bool>& stop) {
  CheckTransportSecurity(e.broker.endpoints, o.insecure);
  MetricsEndpoint metrics("broker", e.metrics.bind, MetricsPort(o, e, e.metrics.broker_port),
                          o.run_id);
  zmq::context_t context(1);
  broker::Broker b(context, e.broker, o.run_id, &metrics);
  std::fprintf(stderr, "broker: listening on %s (actors) and %s (learner), %s\n",
               e.broker.endpoints.Bind(e.broker.endpoints.trajectory_port).c_str(),
               e.broker.endpoints.Bind(e.broker.endpoints.learner_port).c_str(),
               e.broker.endpoints.curve.enabled() ? "CURVE"
               : IsLoopback(e.broker.endpoints.bind)
                   ? "plaintext (loopback only)"
                   : "PLAINTEXT on a network (--insecure): anyone reaching it can train or "
                     "read the policy");
  b.Run(stop);
  return 0;
}

int RunActorRole(const RoleOptions& o, const run::Experiment& e, const std::atomic<bool>& stop) {
  actor::ActorConfig a = e.actor;
  a.run_id = o.run_id;
  a.actor_id = Hostname() + "-actor-" + std::to_string(o.index);
  a.seed = e.actor.seed * 1000003ull + static_cast<uint64_t>(o.index) * 7919ull;
  a.metrics_bind = e.metrics.bind;
  a.metrics_port = MetricsPort(o, e, e.metrics.actor_port + o.index);
  return actor::RunActor(e.environment, a, e.broker.endpoints, stop);
}

int RunLearnerRole(const RoleOptions& o, const run::Experiment& e, const std::atomic<bool>& stop) {
  const sim::EnvSpec spec = sim::MakeEnvSpec(e.environment);
  learner::LearnerProcessConfig l;
  l.run_id = o.run_id;
  l.run_dir = o.run_dir.empty() ? "runs/" + o.run_id : o.run_dir;
  l.label = e.name;
  l.config_text = e.text;
  l.observation_size = spec.observation_size;
  l.action_size = spec.action_size;
  l.figure_names = spec.figure_names;
  l.reward_terms = spec.reward_terms;
  l.resume = o.resume;
  l.init_from = o.init_from;
  l.metrics_bind = e.metrics.bind;
  l.metrics_port = MetricsPort(
      o, e, o.index == 0 ? e.metrics.learner_port : e.metrics.learner_replica_port + o.index);
  l.replica = e.learner;
  if (o.replicas > 0) l.replica.replicas = o.replicas;
  l.replica_id = Hostname() + "-learner-" + std::to_string(o.index);
  return learner::RunLearner(e.trainer, l, e.broker.endpoints, stop);
}

}  // namespace

std::function<int()> AddRoleCommands(CLI::App& app, const std::atomic<bool>& stop) {
  auto o = std::make_shared<RoleOptions>();
  auto* broker_cmd = app.add_subcommand("broker", "run the broker");
  auto* learner_cmd = app.add_subcommand("learner", "run the learner");
  auto* actor_cmd = app.add_subcommand("actor", "run one actor process");
  for (auto* cmd : {broker_cmd, learner_cmd, actor_cmd}) {
    cmd->add_option("config", o->config, "experiment YAML")->required()->envname("RAGDOLL_CONFIG");
    cmd->add_option("--run-id", o->run_id, "run name, shared by every role")
        ->required()
        ->envname("RAGDOLL_RUN_ID");
    cmd->add_option("--port-base", o->port_base, "use ports PORT_BASE..PORT_BASE+4")
        ->envname("RAGDOLL_PORT_BASE");
    cmd->add_option("--metrics-port", o->metrics_port,
                    "Prometheus endpoint port (default: the config's metrics section)")
        ->envname("RAGDOLL_METRICS_PORT");
    cmd->add_option("--keys", o->keys, "CURVE keys folder (default: the config's security.keys)")
        ->envname("RAGDOLL_KEYS");
    cmd->add_option("--key", o->key,
                    "this process's secret certificate (default: KEYS/ROLE.key_secret)")
        ->envname("RAGDOLL_KEY");
  }
  broker_cmd
      ->add_option("--bind", o->bind, "interface to listen on (default: the config's broker.bind)")
      ->envname("RAGDOLL_BROKER_BIND");
  broker_cmd->add_flag("--insecure", o->insecure, "listen beyond loopback without keys")
      ->envname("RAGDOLL_INSECURE");
  for (auto* cmd : {learner_cmd, actor_cmd}) {
    cmd->add_option("--broker-host", o->broker_host, "where the broker is (default: broker.host)")
        ->envname("RAGDOLL_BROKER_HOST");
  }
  learner_cmd->add_option("--run-dir", o->run_dir, "run folder (default: runs/RUN_ID)")
      ->envname("RAGDOLL_RUN_DIR");
  learner_cmd->add_flag("--resume", o->resume, "continue from the newest checkpoint in the run")
      ->envname("RAGDOLL_RESUME");
  learner_cmd->add_option("--init-from", o->init_from, "start from another run's weights");
  learner_cmd
      ->add_option("--replicas", o->replicas,
                   "learner replicas in the group (default: the "
                   "config's learner.replicas)")
      ->envname("RAGDOLL_LEARNER_REPLICAS");
  learner_cmd
      ->add_option("--index", o->index, "replica number on this host, for its id and metrics port")
      ->envname("RAGDOLL_LEARNER_INDEX");
  actor_cmd->add_option("--index", o->index, "actor number, for its id, seed and metrics port")
      ->envname("RAGDOLL_ACTOR_INDEX");
  return [o, broker_cmd, learner_cmd, actor_cmd, &stop]() -> int {
    if (*broker_cmd) return RunBrokerRole(*o, ReadRoleExperiment(*o, "broker"), stop);
    if (*learner_cmd) return RunLearnerRole(*o, ReadRoleExperiment(*o, "learner"), stop);
    if (*actor_cmd) return RunActorRole(*o, ReadRoleExperiment(*o, "actor"), stop);
    return -1;
  };
}

}  // namespace ragdoll::cli
