#include "learner/learner_process.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "common/config_section.h"
#include "common/metrics.h"
#include "common/wire.h"
#include "learner/checkpoint_file.h"
#include "learner/learner.h"
#include "learner/replica_group.h"

namespace ragdoll::learner {
namespace fs = std::filesystem;
namespace {

using Clock = std::chrono::steady_clock;

std::string Duration(double seconds) {
  if (!(seconds >= 0) || seconds > 1e8) return "--:--:--";
  long s = static_cast<long>(seconds);
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
  return buffer;
}

}  // namespace

std::vector<fs::path> Checkpoints(const fs::path& folder) {
  std::vector<fs::path> out;
  if (!fs::is_directory(folder)) return out;
  for (const auto& entry : fs::directory_iterator(folder)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("checkpoint-", 0) == 0 && entry.path().extension() == ".pt") {
      out.push_back(entry.path());
    }
  }
  std::sort(out.begin(), out.end());  // names carry zero-padded sample counts
  return out;
}

// The columns of a new metrics.csv: the learner's own, then one per episode figure.
std::vector<std::string> MetricsColumns(const std::vector<std::string>& figure_names) {
  std::vector<std::string> columns = {
      "iteration",          "version",       "samples",           "elapsed_s",      "samples_per_s",
      "episodes",           "mean_return",   "normalized_return", "episode_length", "fall_rate",
      "policy_loss",        "value_loss",    "entropy",           "approx_kl",      "clip_fraction",
      "explained_variance", "learning_rate", "update_s",          "stale_dropped",  "rejected",
      "idle_fraction",      "update_kl"};
  columns.insert(columns.end(), figure_names.begin(), figure_names.end());
  return columns;
}

namespace {

// The columns an existing metrics.csv names in its first line.
std::vector<std::string> CsvHeader(const fs::path& path) {
  std::ifstream in(path);
  std::string line, cell;
  std::getline(in, line);
  std::vector<std::string> columns;
  std::istringstream cells(line);
  while (std::getline(cells, cell, ',')) columns.push_back(cell);
  return columns;
}

std::string JoinCells(const std::vector<std::string>& cells) {
  std::string line;
  for (const std::string& c : cells) line += (line.empty() ? "" : ",") + c;
  return line;
}

}  // namespace

std::string MetricsRow(const std::vector<std::string>& columns,
                       const std::map<std::string, std::string>& cells) {
  std::vector<std::string> row;
  for (const std::string& c : columns) {
    auto it = cells.find(c);
    row.push_back(it == cells.end() ? "0" : it->second);
  }
  return JoinCells(row);
}

namespace {

// A value as the metrics.csv writes it (an ostream's default format).
template <typename T>
std::string Cell(T value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

// The learner's Prometheus series. Episode and PPO figures are gauges holding the latest PPO
// iteration's means; totals are counters of this process (a resumed run's totals are gauges).
struct LearnerMetrics {
  LearnerMetrics(MetricsEndpoint& m, const std::vector<std::string>& figure_names, int reward_terms)
      : episode_return(
            m.Gauge("ragdoll_episode_return",
                    "Mean undiscounted return of the episodes of the last PPO iteration")),
        normalized_return(m.Gauge("ragdoll_episode_normalized_return",
                                  "Mean return per step relative to the maximum (0..1) of the "
                                  "episodes of the last PPO iteration")),
        episode_length(m.Gauge("ragdoll_episode_length_steps",
                               "Mean episode length in control steps, last PPO iteration")),
        fall_ratio(m.Gauge("ragdoll_episode_fall_ratio",
                           "Fraction of the last PPO iteration's episodes that ended in a fall")),
        episodes(m.Counter("ragdoll_episodes_total", "Episodes finished by all actors")),
        policy_loss(m.Gauge("ragdoll_ppo_policy_loss", "Clipped surrogate loss, last update")),
        value_loss(m.Gauge("ragdoll_ppo_value_loss", "Value loss, last update")),
        entropy(m.Gauge("ragdoll_ppo_entropy", "Policy entropy (nats), last update")),
        approx_kl(m.Gauge("ragdoll_ppo_approx_kl", "Approximate KL divergence, last update")),
        clip_fraction(m.Gauge("ragdoll_ppo_clip_ratio",
                              "Fraction of samples whose ratio was clipped, last update")),
        explained_variance(m.Gauge("ragdoll_ppo_explained_variance",
                                   "Explained variance of the value targets, last update")),
        learning_rate(m.Gauge("ragdoll_ppo_learning_rate", "Adam learning rate")),
        updates(m.Counter("ragdoll_ppo_updates_total", "PPO updates run by this learner process")),
        update_seconds(m.Histogram("ragdoll_ppo_update_duration_seconds",
                                   "Wall time of one PPO update (all epochs)",
                                   {0.25, 0.5, 1, 2, 4, 8, 16, 32, 64})),
        skipped_steps(m.Counter("ragdoll_ppo_skipped_gradient_steps_total",
                                "Gradient steps skipped for a non-finite gradient")),
        samples(m.Counter(
            "ragdoll_learner_samples_total",
            "Samples trained on by this learner process (by its group: counted by replica 0)")),
        run_samples(m.Gauge("ragdoll_learner_run_samples",
                            "Samples trained on in the whole run (continues after a resume)")),
        samples_per_second(m.Gauge("ragdoll_learner_samples_per_second",
                                   "Samples per second over the last PPO iteration")),
        version(m.Gauge("ragdoll_policy_version", "Version of the newest policy")),
        lag(m.Histogram("ragdoll_learner_policy_lag_versions",
                        "Policy versions between a segment's behaviour policy and the learner's",
                        {0, 1, 2, 3, 5, 10, 20})),
        stale(m.Counter("ragdoll_learner_stale_segments_dropped_total",
                        "Segments dropped for exceeding max_policy_lag")),
        checkpoints(m.Counter("ragdoll_learner_checkpoints_total", "Checkpoints written")),
        checkpoint_failures(m.Counter("ragdoll_learner_checkpoint_failures_total",
                                      "Checkpoints that could not be written (full disk, file "
                                      "size limit); training went on")),
        idle_seconds(m.Counter("ragdoll_learner_idle_seconds_total",
                               "Wall time spent waiting for segments (nothing to do)")) {
    for (int i = 0; i < static_cast<int>(figure_names.size()); ++i) {
      figures.push_back(
          i < reward_terms
              ? &m.Gauge("ragdoll_episode_reward_term",
                         "Mean per-step value (0..1) of one reward term (the imitation terms and "
                         "a task's weighted term), last PPO iteration",
                         {{"term", figure_names[i]}})
              : &m.Gauge("ragdoll_episode_figure",
                         "Mean per-step value of one of a task's episode figures (steering: "
                         "speed_error in m/s, heading_error in rad), last PPO iteration",
                         {{"figure", figure_names[i]}}));
    }
    for (int r = 1; r <= static_cast<int>(wire::Rejection::kRunId); ++r) {
      rejected.push_back(&m.Counter(
          "ragdoll_learner_rejected_messages_total", "Messages dropped by the learner, by reason",
          {{"reason", wire::RejectionName(static_cast<wire::Rejection>(r))}}));
    }
  }

  prometheus::Gauge &episode_return, &normalized_return, &episode_length, &fall_ratio;
  prometheus::Counter& episodes;
  prometheus::Gauge &policy_loss, &value_loss, &entropy, &approx_kl, &clip_fraction,
      &explained_variance, &learning_rate;
  prometheus::Counter& updates;
  prometheus::Histogram& update_seconds;
  prometheus::Counter &skipped_steps, &samples;
  prometheus::Gauge &run_samples, &samples_per_second, &version;
  prometheus::Histogram& lag;
  prometheus::Counter &stale, &checkpoints, &checkpoint_failures, &idle_seconds;
  std::vector<prometheus::Gauge*> figures;     // as the environment's figure names
  std::vector<prometheus::Counter*> rejected;  // index: Rejection - 1
};

// Samples of a checkpoint file, from its name; -1 for "".
int64_t CheckpointSamples(const std::string& path) {
  if (path.empty()) return -1;
  const std::string stem = fs::path(path).stem().string();  // checkpoint-000000507904
  try {
    return std::stoll(stem.substr(stem.find('-') + 1));
  } catch (const std::exception&) {
    return 0;
  }
}

// learner.address, else 127.0.0.1 with a broker on loopback, else the address this host's name
// resolves to (a container's address on its compose network), else the name itself.
std::string OwnAddress(const ReplicaSettings& settings, const Endpoints& endpoints) {
  if (!settings.address.empty()) return settings.address;
  if (endpoints.host == "127.0.0.1" || endpoints.host == "localhost") return "127.0.0.1";
  char name[256] = {};
  gethostname(name, sizeof(name) - 1);
  addrinfo hints = {};
  hints.ai_family = AF_INET;
  addrinfo* found = nullptr;
  std::string address = name;
  if (getaddrinfo(name, nullptr, &hints, &found) == 0 && found != nullptr) {
    char ip[INET_ADDRSTRLEN] = {};
    const auto* in = reinterpret_cast<const sockaddr_in*>(found->ai_addr);
    if (inet_ntop(AF_INET, &in->sin_addr, ip, sizeof(ip)) != nullptr &&
        std::string(ip).rfind("127.", 0) != 0) {
      address = ip;
    }
    freeaddrinfo(found);
  }
  return address;
}

// Asks the broker for a place in a group until it answers; nullopt when stopped first.
std::optional<v1::ReplicaAssignment> JoinGroup(zmq::context_t& context,
                                               const LearnerProcessConfig& config,
                                               const Endpoints& endpoints,
                                               int64_t checkpoint_samples,
                                               const std::atomic<bool>& stop) {
  zmq::socket_t control = MakeSocket(context, zmq::socket_type::dealer, endpoints);
  control.set(zmq::sockopt::routing_id, config.replica_id);
  control.connect(endpoints.Connect(endpoints.control_port));
  v1::ReplicaHello hello;
  hello.set_replica_id(config.replica_id);
  hello.set_replicas(config.replica.replicas);
  hello.set_address(OwnAddress(config.replica, endpoints));
  hello.set_store_port(config.replica.store_port);
  hello.set_checkpoint_samples(checkpoint_samples);
  const std::string message =
      wire::Pack(v1::KIND_REPLICA_HELLO, config.run_id, config.replica_id, hello);
  const auto start = Clock::now();
  auto last_hello = start - std::chrono::seconds(1), last_log = start;
  std::fprintf(stderr, "learner: %s asks the broker for a group of %d replicas\n",
               config.replica_id.c_str(), config.replica.replicas);
  while (!stop.load()) {
    if (Clock::now() - last_hello >= std::chrono::seconds(1)) {
      Send(control, zmq::buffer(message), zmq::send_flags::dontwait);
      last_hello = Clock::now();
    }
    if (Clock::now() - last_log > std::chrono::seconds(15)) {
      last_log = Clock::now();
      std::fprintf(stderr, "learner: %s still waiting for %d replicas to join (%.0f s)\n",
                   config.replica_id.c_str(), config.replica.replicas,
                   std::chrono::duration<double>(Clock::now() - start).count());
    }
    zmq::message_t reply;
    if (!Receive(control, reply)) continue;
    v1::Header header;
    v1::ReplicaAssignment assignment;
    wire::Verdict v = wire::ReadMessage(reply.data(), reply.size(), endpoints.max_message_bytes,
                                        &header, &assignment);
    if (v.ok() && header.kind() == v1::KIND_REPLICA_ASSIGNMENT &&
        assignment.replicas() == config.replica.replicas && assignment.rank() >= 0 &&
        assignment.rank() < assignment.replicas()) {
      return assignment;
    }
  }
  return std::nullopt;
}

// The policy version of the broker's cached snapshot (what actors run), or -1 when it has none or
// does not answer within `seconds`.
int64_t BrokerSnapshotVersion(zmq::context_t& context, const LearnerProcessConfig& config,
                              const Endpoints& endpoints, double seconds) {
  zmq::socket_t control = MakeSocket(context, zmq::socket_type::dealer, endpoints);
  control.connect(endpoints.Connect(endpoints.control_port));
  v1::SnapshotRequest request;
  request.set_actor_id("learner");
  request.set_have_version(-1);
  const std::string message =
      wire::Pack(v1::KIND_SNAPSHOT_REQUEST, config.run_id, "learner", request);
  Send(control, zmq::buffer(message), zmq::send_flags::dontwait);
  const auto start = Clock::now();
  while (std::chrono::duration<double>(Clock::now() - start).count() < seconds) {
    zmq::message_t reply;
    if (!Receive(control, reply)) continue;
    v1::Header header;
    size_t offset = 0;
    if (wire::ReadHeader(reply.data(), reply.size(), endpoints.max_message_bytes, &header, &offset)
            .ok() &&
        header.kind() == v1::KIND_SNAPSHOT) {
      return header.policy_version();
    }
    return -1;
  }
  return -1;
}

}  // namespace

ReplicaSettings ReadReplicaSettings(const ConfigSection& section) {
  ReplicaSettings s;
  s.replicas = section.Get<int>("replicas", s.replicas);
  if (s.replicas < 1 || s.replicas > 4096) section.Fail("replicas", "must be 1 to 4096");
  s.store_port = section.GetPort("store_port", s.store_port);
  s.address = section.Get<std::string>("address", s.address);
  s.timeout = section.Get<double>("timeout", s.timeout);
  if (!(s.timeout >= 1)) section.Fail("timeout", "must be at least 1 (seconds)");
  section.Finish();
  return s;
}

std::string FindCheckpoint(const std::string& run_or_checkpoint) {
  fs::path p(run_or_checkpoint);
  if (fs::is_regular_file(p)) return p.string();
  auto all = Checkpoints(p / "checkpoints");
  return all.empty() ? "" : all.back().string();
}

std::string FindGoodCheckpoint(const std::string& run_or_checkpoint,
                               std::vector<std::string>* skipped) {
  fs::path p(run_or_checkpoint);
  if (fs::is_regular_file(p)) {
    std::string damage = CheckCheckpointFile(p.string());
    if (!damage.empty()) throw ConfigError(damage);
    return p.string();
  }
  auto all = Checkpoints(p / "checkpoints");
  for (auto it = all.rbegin(); it != all.rend(); ++it) {
    std::string damage = CheckCheckpointFile(it->string());
    if (damage.empty()) return it->string();
    if (skipped) skipped->push_back(damage);
  }
  return "";
}

int RunLearner(const TrainerConfig& trainer, const LearnerProcessConfig& config,
               const Endpoints& endpoints, const std::atomic<bool>& stop) {
  at::set_num_threads(trainer.threads);
  // Past a file size limit (RLIMIT_FSIZE) a write fails with EFBIG instead of killing us: a
  // checkpoint that does not fit is a logged failure, not a crash.
  std::signal(SIGXFSZ, SIG_IGN);
  const fs::path checkpoints = fs::path(config.run_dir) / "checkpoints";
  fs::create_directories(checkpoints);
  zmq::context_t context(1);

  std::unique_ptr<ReplicaGroup> group;
  if (config.replica.replicas > 1) {
    const int64_t newest =
        config.resume ? CheckpointSamples(FindGoodCheckpoint(config.run_dir)) : -1;
    auto assignment = JoinGroup(context, config, endpoints, newest, stop);
    if (!assignment) return 0;  // stopped before the group formed: nothing trained, nothing to save
    ReplicaGroupConfig g;
    g.rank = assignment->rank();
    g.size = assignment->replicas();
    g.store_host = assignment->store_host();
    g.store_port = assignment->store_port();
    g.address = OwnAddress(config.replica, endpoints);
    g.timeout = std::chrono::milliseconds(static_cast<int64_t>(config.replica.timeout * 1000));
    std::fprintf(stderr, "learner: %s is replica %d of %d (group %lld, store %s:%d)\n",
                 config.replica_id.c_str(), g.rank, g.size,
                 static_cast<long long>(assignment->group()), g.store_host.c_str(), g.store_port);
    group = std::make_unique<ReplicaGroup>(g);
  }
  const int rank = group ? group->rank() : 0;
  const bool leader = rank == 0;  // publishes snapshots, writes checkpoints and the CSV
  torch::manual_seed(trainer.seed + static_cast<uint64_t>(rank));
  Learner learner(trainer, config.observation_size, config.action_size, group.get());
  learner.SetFigureNames(config.figure_names);

  if (!leader) {
    // Rank 0's state arrives below.
  } else if (config.resume) {
    std::vector<std::string> damaged;
    std::string path = FindGoodCheckpoint(config.run_dir, &damaged);
    // A damaged checkpoint is set aside (renamed *.damaged), so that the ones written from here
    // on, whose sample counts are lower, are not deleted before it by keep_checkpoints.
    for (const auto& reason : damaged) {
      const std::string file = reason.substr(0, reason.find(": "));
      std::error_code error;
      fs::rename(file, file + ".damaged", error);
      std::fprintf(stderr, "learner: --resume: %s; set aside as %s.damaged%s\n", reason.c_str(),
                   fs::path(file).filename().c_str(),
                   path.empty() ? "" : ("; using " + path + " instead").c_str());
    }
    if (path.empty()) {
      std::fprintf(stderr, "learner: --resume: no %scheckpoint in %s; starting fresh\n",
                   damaged.empty() ? "" : "good ", checkpoints.c_str());
    } else {
      learner.Load(path);
      std::fprintf(stderr, "learner: resumed from %s at policy v%lld, %lld samples%s\n",
                   path.c_str(), static_cast<long long>(learner.version()),
                   static_cast<long long>(learner.samples()),
                   learner.optimizer_restored()
                       ? ""
                       : " (a shipped checkpoint without optimizer state: Adam starts afresh)");
    }
    // Actors may run a newer version than the checkpoint's (this learner was killed between
    // checkpoints): the numbering continues above it, so that versions never go backward.
    const int64_t running = BrokerSnapshotVersion(context, config, endpoints, 2.0);
    if (running > learner.version()) {
      std::fprintf(stderr,
                   "learner: actors run policy v%lld, newer than the checkpoint's; numbering "
                   "continues from there\n",
                   static_cast<long long>(running));
      learner.ContinueNumberingFrom(running);
    }
  } else if (!config.init_from.empty()) {
    std::string path = FindCheckpoint(config.init_from);
    if (path.empty()) throw ConfigError(config.init_from + ": no checkpoint found");
    learner.LoadWeights(path);
    std::fprintf(stderr, "learner: initialised weights from %s\n", path.c_str());
  }
  learner.SyncFromRankZero();

  MetricsEndpoint endpoint("learner", config.metrics_bind, config.metrics_port, config.run_id);
  LearnerMetrics metrics(endpoint, config.figure_names, config.reward_terms);
  metrics.version.Set(static_cast<double>(learner.version()));
  metrics.run_samples.Set(static_cast<double>(learner.samples()));
  const int64_t start_stale = learner.stale_dropped();

  // A checkpoint that cannot be written (a full disk, a file size limit) is logged and counted;
  // the earlier ones stay, none is deleted for it, and training goes on.
  auto save = [&](const char* why) {
    char name[64];
    std::snprintf(name, sizeof(name), "checkpoint-%012lld.pt",
                  static_cast<long long>(learner.samples()));
    fs::path path = checkpoints / name;
    try {
      learner.Save(path.string(), config.config_text);
    } catch (const std::exception& error) {
      metrics.checkpoint_failures.Increment();
      std::fprintf(stderr, "learner: %s checkpoint FAILED: %s [%lld failures so far]\n", why,
                   error.what(), static_cast<long long>(metrics.checkpoint_failures.Value()));
      return false;
    }
    metrics.checkpoints.Increment();
    auto all = Checkpoints(checkpoints);
    for (size_t i = 0; i + trainer.keep_checkpoints < all.size(); ++i) fs::remove(all[i]);
    std::fprintf(stderr, "learner: %s checkpoint %s\n", why, path.c_str());
    return true;
  };

  // Every replica pulls its share of the segments (the broker's PUSH deals them round-robin);
  // only rank 0 pushes snapshots.
  zmq::socket_t pull = MakeSocket(context, zmq::socket_type::pull, endpoints);
  zmq::socket_t push = MakeSocket(context, zmq::socket_type::push, endpoints);
  ConnectionMonitor monitor(pull, config.replica_id.empty() ? "learner" : config.replica_id,
                            "learner");
  pull.connect(endpoints.Connect(endpoints.learner_port));
  if (leader) push.connect(endpoints.Connect(endpoints.learner_snapshot_port));

  std::string snapshot;
  auto publish = [&]() {
    if (leader) Send(push, zmq::buffer(snapshot), zmq::send_flags::dontwait);
  };
  auto make_snapshot = [&]() {
    if (!leader) return;
    snapshot = wire::Pack(v1::KIND_SNAPSHOT, config.run_id, "learner", learner.Snapshot(),
                          learner.version());
    publish();
  };
  make_snapshot();

  // The run's effective configuration beside its checkpoints, as `ragdoll train` writes it, so
  // that eval, render and verify work on a run whose roles were started one by one.
  if (leader && !config.config_text.empty() &&
      !fs::exists(fs::path(config.run_dir) / "config.yaml")) {
    const fs::path path = fs::path(config.run_dir) / "config.yaml";
    std::ofstream(path.string() + ".tmp") << config.config_text;
    std::error_code error;
    fs::rename(path.string() + ".tmp", path, error);
  }
  const fs::path csv_path = fs::path(config.run_dir) / "metrics.csv";
  bool new_csv = leader && !fs::exists(csv_path);
  // A resumed run keeps its file's columns (an older learner's order or figures); a new one
  // has the fixed columns, then a column per episode figure.
  std::vector<std::string> csv_columns;
  if (leader && !new_csv) csv_columns = CsvHeader(csv_path);
  if (csv_columns.empty()) {
    csv_columns = MetricsColumns(config.figure_names);
    new_csv = leader;
  }
  std::ofstream csv;
  if (leader) csv.open(csv_path, std::ios::app);
  if (new_csv) csv << JoinCells(csv_columns) << "\n";

  const auto start = Clock::now();
  auto last_publish = start, last_iteration = start;
  const int64_t start_samples = learner.samples();
  int64_t next_checkpoint =
      (learner.samples() / trainer.checkpoint_interval + 1) * trainer.checkpoint_interval;
  int64_t rejected_total = 0;
  auto reject = [&](const wire::Verdict& v) {
    metrics.rejected[static_cast<int>(v.rejection) - 1]->Increment();
    if (rejected_total++ % 100 == 0) {
      std::fprintf(stderr, "learner: dropped a segment (%s): %s [%lld dropped so far]\n",
                   wire::RejectionName(v.rejection), v.detail.c_str(),
                   static_cast<long long>(rejected_total));
    }
  };

  // A received message: checked, then buffered, or counted and dropped.
  auto take = [&](const zmq::message_t& message) {
    v1::Header header;
    v1::TrajectorySegment segment;
    wire::Verdict v = wire::ReadMessage(message.data(), message.size(), endpoints.max_message_bytes,
                                        &header, &segment);
    if (v.ok() && header.kind() != v1::KIND_TRAJECTORY) {
      v = {wire::Rejection::kKind, "expected a trajectory segment"};
    }
    if (v.ok() && header.run_id() != config.run_id) {
      v = {wire::Rejection::kRunId, "segment of run '" + header.run_id() + "'"};
    }
    if (v.ok()) v = wire::CheckSegment(segment, config.observation_size, config.action_size);
    if (!v.ok()) return reject(v);
    const int64_t lag = learner.version() - segment.policy_version();
    Learner::Accept a = learner.Add(std::move(segment));
    if (a == Learner::Accept::kWrongLength) {
      reject({wire::Rejection::kShape, "segment length differs from time_horizon"});
    } else if (a == Learner::Accept::kAccepted) {
      metrics.lag.Observe(static_cast<double>(lag));
    }
    AdvanceTo(metrics.stale, static_cast<double>(learner.stale_dropped() - start_stale));
  };
  // A replica whose buffer is full takes fresh segments while the others fill theirs, up to
  // twice its share (Learner::AgreeToUpdate says why), but only once they are late. Replicas
  // that all hold a backlog reach the agreement 1-20 ms apart, and without the wait the first
  // one took its backlog in that time, up to twice its share (8 192 -> 16 384 in 11 ms,
  // ragdoll-bench-cluster --pin). Every gradient step then waited for it: updates took 3-5 s
  // instead of 2.2, the backlog grew, and the group trained less the more it was offered.
  // Each call waits at most 1 ms.
  constexpr auto kLateAfter = std::chrono::milliseconds(50);
  auto take_while_waiting = [&](Clock::time_point waiting_since) {
    if (learner.Full() || Clock::now() - waiting_since < kLateAfter) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      return;
    }
    zmq::pollitem_t item = {pull.handle(), 0, ZMQ_POLLIN, 0};
    zmq::message_t message;
    if (zmq::poll(&item, 1, std::chrono::milliseconds(1)) > 0 &&
        Receive(pull, message, zmq::recv_flags::dontwait)) {
      take(message);
    }
  };

  // Time spent blocked waiting for a segment: the learner's idle time, per iteration.
  double idle_seconds = 0;
  bool stopped = false;
  while (learner.samples() < trainer.max_steps) {
    if (stop.load()) {
      learner.AgreeToUpdate(true);  // replicas stop together
      stopped = true;
      break;
    }
    zmq::message_t message;
    const auto wait_start = Clock::now();
    const bool received = Receive(pull, message);
    monitor.Poll();  // a refused handshake is said in the log
    const double waited = std::chrono::duration<double>(Clock::now() - wait_start).count();
    idle_seconds += waited;
    metrics.idle_seconds.Increment(waited);
    if (received) take(message);
    if (learner.Ready()) {
      const auto ready_at = Clock::now();
      // False: another replica is stopping.
      if (!learner.AgreeToUpdate(false, [&] { take_while_waiting(ready_at); })) {
        stopped = true;
        break;
      }
      UpdateStats u = learner.Update();
      make_snapshot();
      last_publish = Clock::now();
      const EpisodeStatsSum& e = learner.episodes();
      double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
      double iteration_s = std::chrono::duration<double>(Clock::now() - last_iteration).count();
      last_iteration = Clock::now();
      double rate = (learner.samples() - start_samples) / std::max(elapsed, 1e-9);
      const double idle_fraction = idle_seconds / std::max(iteration_s, 1e-9);
      idle_seconds = 0;
      double eta = (trainer.max_steps - learner.samples()) / std::max(rate, 1e-9);
      if (leader)
        std::printf(
            "[%s] it %lld  samples %lld  %.0f/s  return %.2f  norm %.3f  len %.1f  fall %.2f  "
            "v%lld  kl %.4f  idle %.0f%%  elapsed %s  eta %s\n",
            config.label.c_str(), static_cast<long long>(learner.iterations()),
            static_cast<long long>(learner.samples()), rate, e.Mean(e.episode_return),
            e.Mean(e.normalized_return), e.Mean(e.length), e.Mean(e.falls),
            static_cast<long long>(learner.version()), u.approx_kl, 100 * idle_fraction,
            Duration(elapsed).c_str(), Duration(eta).c_str());
      std::fflush(stdout);
      metrics.episode_return.Set(e.Mean(e.episode_return));
      metrics.normalized_return.Set(e.Mean(e.normalized_return));
      metrics.episode_length.Set(e.Mean(e.length));
      metrics.fall_ratio.Set(e.Mean(e.falls));
      // Totals are the group's: replica 0 counts them, so sums over replicas stay right.
      if (leader) metrics.episodes.Increment(static_cast<double>(e.episodes));
      for (size_t i = 0; i < metrics.figures.size(); ++i) {
        metrics.figures[i]->Set(e.Mean(e.figures[i]));
      }
      metrics.policy_loss.Set(u.policy_loss);
      metrics.value_loss.Set(u.value_loss);
      metrics.entropy.Set(u.entropy);
      metrics.approx_kl.Set(u.approx_kl);
      metrics.clip_fraction.Set(u.clip_fraction);
      metrics.explained_variance.Set(u.explained_variance);
      metrics.learning_rate.Set(u.learning_rate);
      metrics.updates.Increment();
      metrics.update_seconds.Observe(u.seconds);
      metrics.skipped_steps.Increment(static_cast<double>(u.skipped_steps));
      if (leader) metrics.samples.Increment(static_cast<double>(u.samples));
      metrics.run_samples.Set(static_cast<double>(learner.samples()));
      metrics.samples_per_second.Set(u.samples / std::max(iteration_s, 1e-9));
      metrics.version.Set(static_cast<double>(learner.version()));
      if (leader) {
        std::map<std::string, std::string> row = {
            {"iteration", Cell(learner.iterations())},
            {"version", Cell(learner.version())},
            {"samples", Cell(learner.samples())},
            {"elapsed_s", Cell(elapsed)},
            {"samples_per_s", Cell(u.samples / std::max(iteration_s, 1e-9))},
            {"episodes", Cell(e.episodes)},
            {"mean_return", Cell(e.Mean(e.episode_return))},
            {"normalized_return", Cell(e.Mean(e.normalized_return))},
            {"episode_length", Cell(e.Mean(e.length))},
            {"fall_rate", Cell(e.Mean(e.falls))},
            {"policy_loss", Cell(u.policy_loss)},
            {"value_loss", Cell(u.value_loss)},
            {"entropy", Cell(u.entropy)},
            {"approx_kl", Cell(u.approx_kl)},
            {"clip_fraction", Cell(u.clip_fraction)},
            {"explained_variance", Cell(u.explained_variance)},
            {"learning_rate", Cell(u.learning_rate)},
            {"update_s", Cell(u.seconds)},
            {"stale_dropped", Cell(learner.stale_dropped())},
            {"rejected", Cell(rejected_total)},
            {"idle_fraction", Cell(idle_fraction)},
            {"update_kl", Cell(u.update_kl)}};
        for (size_t i = 0; i < e.figures.size(); ++i) {
          row[e.figure_names[i]] = Cell(e.Mean(e.figures[i]));
        }
        csv << MetricsRow(csv_columns, row) << "\n";
        csv.flush();
      }
      learner.ResetEpisodeStats();
      if (learner.samples() >= next_checkpoint) {
        if (leader) save("saved");
        next_checkpoint += trainer.checkpoint_interval;
      }
    }
    if (std::chrono::duration<double>(Clock::now() - last_publish).count() >
        config.republish_seconds) {
      publish();
      last_publish = Clock::now();
    }
  }
  if (leader && !save(stopped ? "final (stopped)" : "final (max_steps reached)")) return 1;
  return 0;
}

}  // namespace ragdoll::learner
