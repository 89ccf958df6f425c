#include "cli/launcher.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
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

#include "character/motion_io.h"
#include "cli/motion_commands.h"
#include "common/config_section.h"
#include "common/process.h"
#include "common/run_config.h"
#include "learner/checkpoint_store.h"
#include "motion/clip_kind.h"
#include "motion/clip_report.h"
#include "run/experiment.h"
#include "sim/imitation_env.h"

namespace ragdoll::cli {
namespace fs = std::filesystem;
namespace {

struct TrainOptions {
  std::string config;  // with `motion`: the template (default: chosen for the clip's kind)
  std::string motion;  // a motion file to import and train (`--motion`)
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
  // As ZeroMQ's listeners do: a port whose last run's connections wait in TIME-WAIT binds, one a
  // live listener holds does not.
  int yes = 1;
  setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  const bool free = bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
  close(fd);
  return free;
}

struct Child {
  std::string role;
  std::unique_ptr<ChildProcess> process;  // null when it could not be started
  bool running = false;                   // until its end has been handled
};

std::string DefaultRunId(const std::string& name) {
  std::time_t now = std::time(nullptr);
  char stamp[32];
  std::strftime(stamp, sizeof(stamp), "%Y%m%d-%H%M%S", std::localtime(&now));
  return name + "-" + stamp;
}

// Sends SIGTERM to the running children of `role` and waits up to `seconds`, then SIGKILL.
void Stop(std::vector<Child>& children, const std::string& role, double seconds) {
  for (auto& c : children) {
    if (c.running && c.role.rfind(role, 0) == 0) c.process->Signal(SIGTERM);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  for (auto& c : children) {
    if (!c.running || c.role.rfind(role, 0) != 0) continue;
    const std::chrono::duration<double> left = deadline - std::chrono::steady_clock::now();
    if (!c.process->WaitFor(left.count())) {
      std::fprintf(stderr, "ragdoll train: %s did not stop in %.0f s; killing it\n", c.role.c_str(),
                   seconds);
      c.process->Signal(SIGKILL);
      c.process->Wait();
    }
    c.running = false;
  }
}

// Refuses before anything starts: a broker beyond loopback without keys (the broker would, too),
// and ports another run on this machine holds (its broker would take this run's learner and
// actors; their run ids keep the data apart, but nothing would train).
// --init-from: the source run's observation entries must be the first of this run's (a task's
// entries appended, as recovery's after steering's), so that its weights mean the same here; the
// learner starts the new entries at zero weight.
void CheckInitFrom(const std::string& source, const sim::EnvConfig& env) {
  const std::string checkpoint = learner::FindCheckpoint(source);
  if (checkpoint.empty()) throw ConfigError("--init-from " + source + ": no checkpoint found");
  const fs::path config = RunConfigPath(fs::path(checkpoint).parent_path().parent_path().string());
  if (!fs::exists(config)) return;  // a checkpoint on its own: the learner checks the sizes
  const std::vector<std::string> from =
      sim::MakeEnvSpec(run::ReadExperiment(config.string()).environment).observation_names;
  const std::vector<std::string> to = sim::MakeEnvSpec(env).observation_names;
  const auto [mismatch, unused] = std::mismatch(from.begin(), from.end(), to.begin(), to.end());
  if (mismatch != from.end()) {
    const size_t i = mismatch - from.begin();
    throw ConfigError("--init-from " + source + ": its observation entry " + std::to_string(i) +
                      " is '" + from[i] + "', this run's is '" +
                      (i < to.size() ? to[i] : std::string("(none)")) +
                      "'; a run can start from one whose observation entries its own begin with");
  }
  if (to.size() > from.size()) {
    std::fprintf(stderr,
                 "ragdoll train: --init-from %s: %zu new observation entries (%s, ...) start at "
                 "zero weight\n",
                 source.c_str(), to.size() - from.size(), to[from.size()].c_str());
  }
}

void CheckBeforeStart(Endpoints& endpoints, const std::string& keys, bool insecure) {
  endpoints.curve = LoadCurve(keys, "broker");
  CheckTransportSecurity(endpoints, insecure);
  for (int port : {endpoints.trajectory_port, endpoints.control_port, endpoints.snapshot_port,
                   endpoints.learner_port, endpoints.learner_snapshot_port}) {
    if (!PortFree(port)) {
      throw ConfigError("ragdoll train: port " + std::to_string(port) +
                        " is in use (another training on this machine?); give this run its own "
                        "ports with --port-base, e.g. --port-base " +
                        std::to_string(endpoints.trajectory_port + 100));
    }
  }
}

// The run folder with the effective configuration in it.
fs::path MakeRunFolder(const TrainOptions& options, const std::string& run_id,
                       const run::Experiment& e) {
  const fs::path run_dir = fs::path(options.runs_dir) / run_id;
  fs::create_directories(run_dir);
  WriteRunConfig(run_dir.string(), e.text, /*replace=*/true);
  return run_dir;
}

// The children of one run: started, watched (a failed broker or learner group restarted a few
// times), and stopped in order.
class Supervisor {
 public:
  Supervisor(const TrainOptions& options, const std::string& run_id, fs::path run_dir, int replicas)
      : options_(options), run_dir_(std::move(run_dir)), replicas_(replicas) {
    common_ = {options.config, "--run-id", run_id};
    if (!options.keys.empty()) common_.insert(common_.end(), {"--keys", options.keys});
    if (options.port_base > 0) {
      common_.push_back("--port-base");
      common_.push_back(std::to_string(options.port_base));
    }
  }

  void LaunchBroker() {
    Launch("broker", Args("broker", options_.insecure ? std::vector<std::string>{"--insecure"}
                                                      : std::vector<std::string>{}));
  }

  // The learner, or a group of replicas that the broker ranks. A replica that fails breaks the
  // group: the others stop, and the whole group restarts from the last checkpoint.
  void LaunchLearners(bool resume) {
    for (int i = 0; i < replicas_; ++i) {
      std::vector<std::string> extra = {"--run-dir", run_dir_.string()};
      if (resume) extra.push_back("--resume");
      if (!resume && !options_.init_from.empty()) {
        extra.push_back("--init-from");
        extra.push_back(options_.init_from);
      }
      if (replicas_ > 1) {
        extra.insert(extra.end(),
                     {"--replicas", std::to_string(replicas_), "--index", std::to_string(i)});
      }
      Launch(replicas_ > 1 ? "learner-" + std::to_string(i) : "learner", Args("learner", extra));
    }
  }

  void LaunchActor(int index) {
    Launch("actor-" + std::to_string(index), Args("actor", {"--index", std::to_string(index)}));
  }

  // Waits on the children until `stop` or the learner's end; the run's exit code.
  int Watch(const std::atomic<bool>& stop) {
    while (!stop.load()) {
      Child* child = FirstEnded();
      if (child == nullptr) {
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        continue;
      }
      const Exit ended = Reap(*child, stop);
      if (ended.broker_failed) {
        if (!RestartBroker()) return 1;
        continue;
      }
      if (ended.group_broke) {
        if (!RestartLearners()) return 1;
        continue;
      }
      bool learner_running = false;
      for (const auto& c : children_) {
        learner_running |= c.role.rfind("learner", 0) == 0 && c.running;
      }
      if (!learner_running) break;
    }
    return exit_code_;
  }

  // Actors first (nothing to save), then the learner (final checkpoint), then the broker.
  void StopAll() {
    Stop(children_, "actor", 10);
    Stop(children_, "learner", 60);
    Stop(children_, "broker", 10);
  }

 private:
  static constexpr int kMaxRestarts = 5;

  // What a child's exit asks of the run.
  struct Exit {
    bool group_broke = false, broker_failed = false;
  };

  // `ragdoll ROLE CONFIG --run-id ID [--keys] [--port-base]`, then `extra`.
  std::vector<std::string> Args(const std::string& role, std::vector<std::string> extra) const {
    std::vector<std::string> a = {"ragdoll", role};
    a.insert(a.end(), common_.begin(), common_.end());
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  }

  // `ragdoll ROLE ...` again, in this process group: Ctrl-C at the terminal reaches every role.
  void Launch(const std::string& role, const std::vector<std::string>& args) {
    Child c;
    c.role = role;
    ChildProcess::Options options;
    options.program = kThisProgram;
    options.exec_error = "ragdoll train: exec: %m\n";
    try {
      c.process = std::make_unique<ChildProcess>(args, options);
    } catch (const std::runtime_error&) {
      // No process (fork failed): as one that ended unseen; the run goes on without it.
    }
    c.running = c.process != nullptr;
    children_.push_back(std::move(c));
  }

  // The first child whose end has not been handled yet; null while all run.
  Child* FirstEnded() {
    for (auto& c : children_) {
      if (c.running && !c.process->Running()) return &c;
    }
    return nullptr;
  }

  // Records the end of `c` and says what it means: a failed single learner fails the run.
  Exit Reap(Child& c, const std::atomic<bool>& stop) {
    Exit ended;
    c.running = false;
    const int status = c.process->status();
    bool ok = WIFEXITED(status) && WEXITSTATUS(status) == 0;
    if (c.role.rfind("learner", 0) == 0) {
      if (!ok && replicas_ > 1 && !stop.load()) {
        ended.group_broke = true;
        std::fprintf(stderr, "ragdoll train: %s failed (%s)\n", c.role.c_str(),
                     WIFSIGNALED(status) ? strsignal(WTERMSIG(status)) : "exit");
      } else if (!ok) {
        exit_code_ = 1;
        std::fprintf(stderr, "ragdoll train: the learner failed\n");
      }
    } else {
      std::fprintf(stderr, "ragdoll train: %s exited (%s)%s\n", c.role.c_str(),
                   WIFSIGNALED(status) ? strsignal(WTERMSIG(status)) : "exit",
                   c.role == "broker" ? "" : "; training continues with the others");
      // Without its broker nothing trains, and the others would wait on it forever.
      if (c.role == "broker" && !stop.load()) ended.broker_failed = true;
    }
    return ended;
  }

  // Actors and learner reconnect to a restarted broker on their own (the chaos test shows it);
  // a broker that cannot stay up stops the run (false).
  bool RestartBroker() {
    if (broker_restarts_ == kMaxRestarts) {
      std::fprintf(stderr, "ragdoll train: the broker stopped %d times; giving up\n",
                   kMaxRestarts + 1);
      return false;
    }
    ++broker_restarts_;
    std::fprintf(stderr, "ragdoll train: restarting the broker (restart %d of at most %d)\n",
                 broker_restarts_, kMaxRestarts);
    LaunchBroker();
    return true;
  }

  // The whole group again from the last checkpoint; false when it broke too often.
  bool RestartLearners() {
    if (group_restarts_ == kMaxRestarts) {
      std::fprintf(stderr, "ragdoll train: the learner group broke %d times; giving up\n",
                   kMaxRestarts + 1);
      return false;
    }
    ++group_restarts_;
    Stop(children_, "learner", 60);
    std::fprintf(stderr,
                 "ragdoll train: restarting the %d learner replicas from the last checkpoint "
                 "(restart %d of at most %d)\n",
                 replicas_, group_restarts_, kMaxRestarts);
    LaunchLearners(true);
    return true;
  }

  const TrainOptions& options_;
  const fs::path run_dir_;
  const int replicas_;
  std::vector<std::string> common_;  // the options every role gets
  std::vector<Child> children_;
  int exit_code_ = 0;
  int group_restarts_ = 0, broker_restarts_ = 0;
};

// `train --motion FILE`: the file imported with `motion import`'s defaults, a config template
// chosen for the clip's kind (or the one given), and both written into the run's folder as
// `motion.json` and `<name>.yaml`; returns the options that train from them. A resumed run
// keeps what its folder holds.
TrainOptions PrepareMotionRun(TrainOptions options) {
  const std::string stem = fs::path(options.motion).stem().string();
  if (options.run_id.empty()) options.run_id = DefaultRunId(stem);
  const fs::path run_dir = fs::path(options.runs_dir) / options.run_id;
  const fs::path config = run_dir / (stem + ".yaml");
  if (options.resume) {
    if (!fs::exists(config)) {
      throw ConfigError(config.string() + ": no such file: --resume --motion continues a run " +
                        "that `train --motion` started (its folder holds the clip and config)");
    }
    std::fprintf(stderr, "ragdoll train: resuming %s with its own clip and config (%s)\n",
                 options.run_id.c_str(), config.c_str());
    options.config = config.string();
    return options;
  }
  ImportedMotion imported = ImportMotionFile(options.motion);
  for (const auto& note : imported.notes) std::fprintf(stderr, "  %s\n", note.c_str());
  auto character = character::Character::Load(character::DefaultCharacterPath());
  const motion::ClipKindChoice kind =
      motion::ClassifyClip(imported.clip, motion::InspectClip(imported.clip, *character));
  const std::string template_path = options.config.empty()
                                        ? std::string(RAGDOLL_CONFIGS_DIR) + "/" + kind.config
                                        : options.config;
  std::fprintf(stderr, "ragdoll train: %s: %s (%s): %s %s\n", options.motion.c_str(),
               kind.name.c_str(), kind.reason.c_str(),
               options.config.empty() ? "config template" : "config (given)",
               template_path.c_str());
  YAML::Node tree;
  try {
    tree = YAML::LoadFile(template_path);
  } catch (const YAML::Exception& e) {
    throw ConfigError(template_path + ": " + e.what());
  }
  tree["environment"]["motion"] = "motion.json";
  fs::create_directories(run_dir);
  character::SaveClip(imported.clip, imported.description, (run_dir / "motion.json").string());
  YAML::Emitter out;
  out << tree;
  std::ofstream(config) << "# " << kind.name << " from " << options.motion << ", template "
                        << template_path << "\n"
                        << out.c_str() << "\n";
  std::fprintf(stderr,
               "ragdoll train: clip and config in %s (motion.json, %s); continue it with "
               "`ragdoll train %s --run-id %s --resume`\n",
               run_dir.c_str(), config.filename().c_str(), config.c_str(), options.run_id.c_str());
  options.config = config.string();
  return options;
}

int RunTrain(const TrainOptions& given, const std::atomic<bool>& stop) {
  const TrainOptions options = given.motion.empty() ? given : PrepareMotionRun(given);
  run::Experiment e = run::ReadExperiment(options.config, options.port_base);
  if (!options.init_from.empty() && !options.resume)
    CheckInitFrom(options.init_from, e.environment);
  const std::string keys = options.keys.empty() ? e.keys_dir : options.keys;
  CheckBeforeStart(e.broker.endpoints, keys, options.insecure);
  const std::string run_id = options.run_id.empty() ? DefaultRunId(e.name) : options.run_id;
  const fs::path run_dir = MakeRunFolder(options, run_id, e);
  std::string contacts;
  for (const auto& body : e.environment.allowed_contacts) contacts += " " + body;
  std::fprintf(stderr, "ragdoll train: bodies allowed on the ground (%s):%s\n",
               e.environment.contacts_from_clip ? "auto: the feet and what the clip puts there"
                                                : "from the config",
               contacts.c_str());
  const int actors = options.actors > 0 ? options.actors : run::ResolveActorCount(e.actor_count);
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

  Supervisor children(options, run_id, run_dir, replicas);
  children.LaunchBroker();
  children.LaunchLearners(options.resume);
  for (int i = 0; i < actors; ++i) children.LaunchActor(i);
  const int exit_code = children.Watch(stop);
  children.StopAll();
  std::fprintf(stderr, "ragdoll train: stopped; run folder %s\n", run_dir.c_str());
  return exit_code;
}

}  // namespace

std::function<int()> AddTrainCommand(CLI::App& app, const std::atomic<bool>& stop) {
  auto o = std::make_shared<TrainOptions>();
  auto* cmd = app.add_subcommand("train", "broker, learner and actors on this machine");
  cmd->add_option("config", o->config,
                  "experiment YAML (configs/*.yaml); with --motion, the template to use instead "
                  "of the one chosen for the clip");
  cmd->add_option("--motion", o->motion,
                  "train this clip (BVH, FBX, glTF, COLLADA, the project's .json, DeepMimic's "
                  ".txt): imported with `motion import`'s defaults, the config chosen for its "
                  "kind, both kept in the run folder")
      ->check(CLI::ExistingFile);
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
    if (o->config.empty() && o->motion.empty()) {
      throw ConfigError("ragdoll train: give a config (configs/*.yaml) or --motion FILE");
    }
    return RunTrain(*o, stop);
  };
}

}  // namespace ragdoll::cli
