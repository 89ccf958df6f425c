#include "cli/launcher.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "cli/experiment.h"
#include "common/config_section.h"

namespace ragdoll::cli {
namespace fs = std::filesystem;
namespace {

struct TrainOptions {
  std::string config;
  std::string run_id;  // default: <config name>-<date>-<time>
  std::string runs_dir = "runs";
  bool resume = false;
  std::string init_from;
  int actors = 0;  // 0: from the config (actors.count), else cores - 1
  int port_base = 0;
  int replicas = 0;       // learner replicas; 0: from the config (learner.replicas)
  std::string keys;       // CURVE keys folder for every role; empty: the config's security.keys
  bool insecure = false;  // let the broker listen beyond loopback without keys
};

// Whether a TCP port can be bound on this machine's loopback (nothing else listens there).
bool PortFree(int port) {
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return true;  // cannot tell; the broker will say
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const bool free = bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
  close(fd);
  return free;
}

struct Child {
  std::string role;
  pid_t pid = -1;
  bool running = false;
  int status = 0;
};

pid_t Spawn(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = fork();
  if (pid == 0) {
    execv("/proc/self/exe", argv.data());
    std::perror("ragdoll train: exec");
    _exit(127);
  }
  return pid;
}

std::string DefaultRunId(const std::string& name) {
  std::time_t now = std::time(nullptr);
  char stamp[32];
  std::strftime(stamp, sizeof(stamp), "%Y%m%d-%H%M%S", std::localtime(&now));
  return name + "-" + stamp;
}

// Sends SIGTERM to the running children of `role` and waits up to `seconds`, then SIGKILL.
void Stop(std::vector<Child>& children, const std::string& role, double seconds) {
  for (auto& c : children) {
    if (c.running && c.role.rfind(role, 0) == 0) kill(c.pid, SIGTERM);
  }
  auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  for (auto& c : children) {
    if (!c.running || c.role.rfind(role, 0) != 0) continue;
    while (c.running) {
      if (waitpid(c.pid, &c.status, WNOHANG) == c.pid) {
        c.running = false;
      } else if (std::chrono::steady_clock::now() > deadline) {
        std::fprintf(stderr, "ragdoll train: %s did not stop in %.0f s; killing it\n",
                     c.role.c_str(), seconds);
        kill(c.pid, SIGKILL);
        waitpid(c.pid, &c.status, 0);
        c.running = false;
      } else {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
    }
  }
}

int RunTrain(const TrainOptions& options, const std::atomic<bool>& stop) {
  Experiment e = ReadExperiment(options.config, options.port_base);
  // Refuse before anything starts (the broker would, too).
  const std::string keys = options.keys.empty() ? e.keys_dir : options.keys;
  e.broker.endpoints.curve = LoadCurve(keys, "broker");
  CheckTransportSecurity(e.broker.endpoints, options.insecure);
  // Another run on this machine holds the ports: its broker would take this run's learner and
  // actors (their run ids keep the data apart, but nothing would train). Say so before starting.
  const Endpoints& ports = e.broker.endpoints;
  for (int port : {ports.trajectory_port, ports.control_port, ports.snapshot_port,
                   ports.learner_port, ports.learner_snapshot_port}) {
    if (!PortFree(port)) {
      throw ConfigError("ragdoll train: port " + std::to_string(port) +
                        " is in use (another training on this machine?); give this run its own "
                        "ports with --port-base, e.g. --port-base " +
                        std::to_string(ports.trajectory_port + 100));
    }
  }
  const std::string run_id = options.run_id.empty() ? DefaultRunId(e.name) : options.run_id;
  const fs::path run_dir = fs::path(options.runs_dir) / run_id;
  fs::create_directories(run_dir);
  {
    std::ofstream out(run_dir / "config.yaml");
    out << e.text;
  }
  std::string contacts;
  for (const auto& body : e.environment.allowed_contacts) contacts += " " + body;
  std::fprintf(stderr, "ragdoll train: bodies allowed on the ground (%s):%s\n",
               e.environment.contacts_from_clip ? "auto: the feet and what the clip puts there"
                                                : "from the config",
               contacts.c_str());
  const int actors = options.actors > 0 ? options.actors : ResolveActorCount(e.actor_count);
  const int replicas = options.replicas > 0 ? options.replicas : e.learner.replicas;
  std::fprintf(stderr,
               "ragdoll train: run %s in %s: 1 broker, %d learner%s, %d actor%s x %d "
               "environments\n",
               run_id.c_str(), run_dir.c_str(), replicas, replicas == 1 ? "" : " replicas", actors,
               actors == 1 ? "" : "s", e.actor.environments);
  std::fprintf(
      stderr, "ragdoll train: broker on %s, %s\n",
      e.broker.endpoints.Bind(e.broker.endpoints.trajectory_port).c_str(),
      e.broker.endpoints.curve.enabled() ? ("CURVE keys from " + keys).c_str() : "plaintext");

  std::vector<std::string> common = {options.config, "--run-id", run_id};
  if (!options.keys.empty()) common.insert(common.end(), {"--keys", options.keys});
  if (options.port_base > 0) {
    common.push_back("--port-base");
    common.push_back(std::to_string(options.port_base));
  }
  auto args = [&common](const std::string& role, std::vector<std::string> extra) {
    std::vector<std::string> a = {"ragdoll", role};
    a.insert(a.end(), common.begin(), common.end());
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  };
  std::vector<Child> children;
  auto launch = [&children](const std::string& role, const std::vector<std::string>& a) {
    Child c;
    c.role = role;
    c.pid = Spawn(a);
    c.running = c.pid > 0;
    children.push_back(c);
  };
  launch("broker", args("broker", options.insecure ? std::vector<std::string>{"--insecure"}
                                                   : std::vector<std::string>{}));
  // The learner, or a group of replicas that the broker ranks. A replica that fails breaks the
  // group: the others stop, and the whole group restarts from the last checkpoint.
  auto launch_learners = [&](bool resume) {
    for (int i = 0; i < replicas; ++i) {
      std::vector<std::string> extra = {"--run-dir", run_dir.string()};
      if (resume) extra.push_back("--resume");
      if (!resume && !options.init_from.empty()) {
        extra.push_back("--init-from");
        extra.push_back(options.init_from);
      }
      if (replicas > 1) {
        extra.insert(extra.end(),
                     {"--replicas", std::to_string(replicas), "--index", std::to_string(i)});
      }
      launch(replicas > 1 ? "learner-" + std::to_string(i) : "learner", args("learner", extra));
    }
  };
  launch_learners(options.resume);
  for (int i = 0; i < actors; ++i) {
    launch("actor-" + std::to_string(i), args("actor", {"--index", std::to_string(i)}));
  }

  int exit_code = 0;
  int group_restarts = 0, broker_restarts = 0;
  const int kMaxGroupRestarts = 5;
  while (!stop.load()) {
    int status = 0;
    pid_t pid = waitpid(-1, &status, WNOHANG);
    if (pid <= 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      continue;
    }
    bool group_broke = false, broker_failed = false;
    for (auto& c : children) {
      if (c.pid != pid) continue;
      c.running = false;
      c.status = status;
      bool ok = WIFEXITED(status) && WEXITSTATUS(status) == 0;
      if (c.role.rfind("learner", 0) == 0) {
        if (!ok && replicas > 1 && !stop.load()) {
          group_broke = true;
          std::fprintf(stderr, "ragdoll train: %s failed (%s)\n", c.role.c_str(),
                       WIFSIGNALED(status) ? strsignal(WTERMSIG(status)) : "exit");
        } else if (!ok) {
          exit_code = 1;
          std::fprintf(stderr, "ragdoll train: the learner failed\n");
        }
      } else {
        std::fprintf(stderr, "ragdoll train: %s exited (%s)%s\n", c.role.c_str(),
                     WIFSIGNALED(status) ? strsignal(WTERMSIG(status)) : "exit",
                     c.role == "broker" ? "" : "; training continues with the others");
        // Without its broker nothing trains, and the others would wait on it forever.
        if (c.role == "broker" && !stop.load()) broker_failed = true;
      }
    }
    if (broker_failed) {
      // Actors and learner reconnect to a restarted broker on their own (the chaos test shows
      // it); a broker that cannot stay up stops the run.
      if (broker_restarts == kMaxGroupRestarts) {
        std::fprintf(stderr, "ragdoll train: the broker stopped %d times; giving up\n",
                     kMaxGroupRestarts + 1);
        exit_code = 1;
        break;
      }
      ++broker_restarts;
      std::fprintf(stderr, "ragdoll train: restarting the broker (restart %d of at most %d)\n",
                   broker_restarts, kMaxGroupRestarts);
      launch("broker", args("broker", options.insecure ? std::vector<std::string>{"--insecure"}
                                                       : std::vector<std::string>{}));
      continue;
    }
    if (group_broke) {
      if (group_restarts == kMaxGroupRestarts) {
        std::fprintf(stderr, "ragdoll train: the learner group broke %d times; giving up\n",
                     kMaxGroupRestarts + 1);
        exit_code = 1;
        break;
      }
      ++group_restarts;
      Stop(children, "learner", 60);
      std::fprintf(stderr,
                   "ragdoll train: restarting the %d learner replicas from the last checkpoint "
                   "(restart %d of at most %d)\n",
                   replicas, group_restarts, kMaxGroupRestarts);
      launch_learners(true);
      continue;
    }
    bool learner_running = false;
    for (const auto& c : children) learner_running |= c.role.rfind("learner", 0) == 0 && c.running;
    if (!learner_running) break;
  }
  // Actors first (nothing to save), then the learner (final checkpoint), then the broker.
  Stop(children, "actor", 10);
  Stop(children, "learner", 60);
  Stop(children, "broker", 10);
  std::fprintf(stderr, "ragdoll train: stopped; run folder %s\n", run_dir.c_str());
  return exit_code;
}

}  // namespace

std::function<int()> AddTrainCommand(CLI::App& app, const std::atomic<bool>& stop) {
  auto o = std::make_shared<TrainOptions>();
  auto* cmd = app.add_subcommand("train", "broker, learner and actors on this machine");
  cmd->add_option("config", o->config, "experiment YAML (configs/*.yaml)")->required();
  cmd->add_option("--run-id", o->run_id, "run name (default: config name and time)");
  cmd->add_option("--runs-dir", o->runs_dir, "where run folders go")->capture_default_str();
  cmd->add_flag("--resume", o->resume, "continue the run --run-id from its checkpoint");
  cmd->add_option("--init-from", o->init_from, "start from another run's weights");
  cmd->add_option("--actors", o->actors, "actor processes (default: cores - 1)");
  cmd->add_option("--port-base", o->port_base, "use ports PORT_BASE..PORT_BASE+4");
  cmd->add_option("--replicas", o->replicas,
                  "learner replicas (default: the config's learner.replicas)");
  cmd->add_option("--keys", o->keys,
                  "CURVE keys folder (`ragdoll keygen`; default: security.keys)");
  cmd->add_flag("--insecure", o->insecure, "let the broker listen beyond loopback without keys");
  return [cmd, o, &stop]() -> int {
    if (!*cmd) return -1;
    return RunTrain(*o, stop);
  };
}

}  // namespace ragdoll::cli
