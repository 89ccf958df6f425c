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
#include <memory>
#include <optional>
#include <thread>
#include <utility>
#include <vector>

#include "common/blas.h"
#include "common/config_section.h"
#include "common/metrics.h"
#include "common/run_config.h"
#include "common/wire.h"
#include "learner/checkpoint_store.h"
#include "learner/learner.h"
#include "learner/raw_training.h"
#include "learner/replica_group.h"
#include "learner/training_log.h"

namespace ragdoll::learner {
namespace fs = std::filesystem;
namespace {

using Clock = std::chrono::steady_clock;

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

// Joins the group of replicas (config.replica) through the broker; nullptr when stopped first.
std::unique_ptr<ReplicaGroup> JoinReplicas(zmq::context_t& context,
                                           const LearnerProcessConfig& config,
                                           const Endpoints& endpoints,
                                           const std::atomic<bool>& stop) {
  const int64_t newest = config.resume ? CheckpointSamples(FindGoodCheckpoint(config.run_dir)) : -1;
  auto assignment = JoinGroup(context, config, endpoints, newest, stop);
  if (!assignment) return nullptr;
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
  return std::make_unique<ReplicaGroup>(g);
}

// The leader's starting state: the newest good checkpoint (--resume), or another run's weights
// (--init-from), or the fresh initialisation.
void Restore(Learner& learner, CheckpointStore& store, zmq::context_t& context,
             const LearnerProcessConfig& config, const Endpoints& endpoints) {
  if (config.resume) {
    std::vector<std::string> damaged;
    std::string path = store.NewestGood(&damaged);
    for (const auto& reason : damaged) {
      const std::string file = reason.substr(0, reason.find(": "));
      std::fprintf(stderr, "learner: --resume: %s; set aside as %s.damaged%s\n", reason.c_str(),
                   fs::path(file).filename().c_str(),
                   path.empty() ? "" : ("; using " + path + " instead").c_str());
    }
    if (path.empty()) {
      std::fprintf(stderr, "learner: --resume: no %scheckpoint in %s; starting fresh\n",
                   damaged.empty() ? "" : "good ", store.folder().c_str());
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
}

// The run's effective configuration beside its checkpoints, as `ragdoll train` writes it, so
// that eval, render and verify work on a run whose roles were started one by one.
void WriteRunConfig(const LearnerProcessConfig& config) {
  if (config.config_text.empty()) return;
  try {
    ragdoll::WriteRunConfig(config.run_dir, config.config_text);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "learner: %s (the checkpoints hold the config too)\n", error.what());
  }
}

// The segments the broker deals this replica (its PUSH deals them round-robin): each checked,
// then buffered in the learner, or counted and dropped.
class SegmentIntake {
 public:
  SegmentIntake(zmq::context_t& context, const LearnerProcessConfig& config,
                const Endpoints& endpoints, Learner& learner, TrainingLog& log)
      : config_(config),
        endpoints_(endpoints),
        learner_(learner),
        log_(log),
        pull_(MakeSocket(context, zmq::socket_type::pull, endpoints)),
        monitor_(pull_, config.replica_id.empty() ? "learner" : config.replica_id, "learner") {
    pull_.connect(endpoints.Connect(endpoints.learner_port));
  }

  // Waits for a segment up to the socket's receive timeout, counting the wait as idle time.
  void Receive() {
    zmq::message_t message;
    const auto wait_start = Clock::now();
    const bool received = ragdoll::Receive(pull_, message);
    monitor_.Poll();  // a refused handshake is said in the log
    log_.Idle(std::chrono::duration<double>(Clock::now() - wait_start).count());
    if (received) Take(message);
  }

  // A replica whose buffer is full takes fresh segments while the others fill theirs, up to
  // twice its share (Learner::AgreeToUpdate says why), but only once they are late: replicas
  // that all hold a backlog agree within milliseconds, and one that took its backlog in that
  // time made every gradient step wait for it (docs/learner-scaling.md). Each call waits at
  // most 1 ms.
  void TakeWhileWaiting(Clock::time_point waiting_since) {
    constexpr auto kLateAfter = std::chrono::milliseconds(50);
    if (learner_.Full() || Clock::now() - waiting_since < kLateAfter) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      return;
    }
    zmq::pollitem_t item = {pull_.handle(), 0, ZMQ_POLLIN, 0};
    zmq::message_t message;
    if (zmq::poll(&item, 1, std::chrono::milliseconds(1)) > 0 &&
        ragdoll::Receive(pull_, message, zmq::recv_flags::dontwait)) {
      Take(message);
    }
  }

 private:
  void Take(const zmq::message_t& message) {
    v1::Header header;
    v1::TrajectorySegment segment;
    wire::Verdict v = wire::ReadMessage(message.data(), message.size(),
                                        endpoints_.max_message_bytes, &header, &segment);
    if (v.ok() && header.kind() != v1::KIND_TRAJECTORY) {
      v = {wire::Rejection::kKind, "expected a trajectory segment"};
    }
    if (v.ok() && header.run_id() != config_.run_id) {
      v = {wire::Rejection::kRunId, "segment of run '" + header.run_id() + "'"};
    }
    if (v.ok()) v = wire::CheckSegment(segment, config_.observation_size, config_.action_size);
    if (!v.ok()) return log_.Rejected(v);
    const int64_t lag = learner_.version() - segment.policy_version();
    Learner::Accept a = learner_.Add(std::move(segment));
    if (a == Learner::Accept::kWrongLength) {
      log_.Rejected({wire::Rejection::kShape, "segment length differs from time_horizon"});
    } else if (a == Learner::Accept::kAccepted) {
      log_.Accepted(lag);
    }
    log_.CountStale(learner_.stale_dropped());
  }

  const LearnerProcessConfig& config_;
  const Endpoints& endpoints_;
  Learner& learner_;
  TrainingLog& log_;
  zmq::socket_t pull_;
  ConnectionMonitor monitor_;
};

// Rank 0's policy snapshots to the broker: one after each update, and the same one again every
// republish_seconds, so that a restarted broker has it. The other replicas publish nothing.
class SnapshotPublisher {
 public:
  SnapshotPublisher(zmq::context_t& context, const LearnerProcessConfig& config,
                    const Endpoints& endpoints, bool leader)
      : config_(config),
        leader_(leader),
        push_(MakeSocket(context, zmq::socket_type::push, endpoints)) {
    if (leader) push_.connect(endpoints.Connect(endpoints.learner_snapshot_port));
  }

  void Publish(Learner& learner) {
    if (leader_) {
      snapshot_ = wire::Pack(v1::KIND_SNAPSHOT, config_.run_id, "learner", learner.Snapshot(),
                             learner.version());
    }
    Send();
  }

  void RepublishWhenDue() {
    if (std::chrono::duration<double>(Clock::now() - last_).count() > config_.republish_seconds) {
      Send();
    }
  }

 private:
  void Send() {
    if (leader_) ragdoll::Send(push_, zmq::buffer(snapshot_), zmq::send_flags::dontwait);
    last_ = Clock::now();
  }

  const LearnerProcessConfig& config_;
  bool leader_;
  zmq::socket_t push_;
  std::string snapshot_;
  Clock::time_point last_ = Clock::now();
};

// What this network's gradient steps run at on one thread with nothing else in the way: a
// small network runs far below the sgemm figure, so that figure alone cannot judge the update.
double MeasureRawGflops(const TrainerConfig& trainer, const LearnerProcessConfig& config,
                        const Learner& learner) {
  at::set_num_threads(1);
  RawTraining raw(trainer, config.observation_size, config.action_size, learner.minibatch_size());
  const double raw_gflops = 6e-9 * static_cast<double>(raw.parameters()) * raw.BestRate(20, 0.3);
  at::set_num_threads(trainer.threads);
  return raw_gflops;
}

// A checkpoint that cannot be written (a full disk, a file size limit) is logged and counted;
// the earlier ones stay, none is deleted for it, and training goes on.
bool SaveCheckpoint(CheckpointStore& store, Learner& learner, const LearnerProcessConfig& config,
                    TrainingLog& log, const char* why) {
  std::string path;
  try {
    path = store.Save(learner, config.config_text);
  } catch (const std::exception& error) {
    log.CheckpointFailed(why, error.what());
    return false;
  }
  store.DeleteBeyondKeep();
  log.CheckpointWritten(why, path);
  return true;
}

// Takes segments and updates until max_steps, the leader checkpointing every
// checkpoint_interval samples. True when stopped first (`stop`, or another replica stopping).
bool Train(const TrainerConfig& trainer, const LearnerProcessConfig& config,
           const std::atomic<bool>& stop, bool leader, Learner& learner, CheckpointStore& store,
           TrainingLog& log, SegmentIntake& intake, SnapshotPublisher& publisher) {
  int64_t next_checkpoint =
      (learner.samples() / trainer.checkpoint_interval + 1) * trainer.checkpoint_interval;
  bool stopped = false;
  while (learner.samples() < trainer.max_steps) {
    if (stop.load()) {
      learner.AgreeToUpdate(true);  // replicas stop together
      stopped = true;
      break;
    }
    intake.Receive();
    if (learner.Ready()) {
      const auto ready_at = Clock::now();
      // False: another replica is stopping.
      if (!learner.AgreeToUpdate(false, [&] { intake.TakeWhileWaiting(ready_at); })) {
        stopped = true;
        break;
      }
      UpdateStats u = learner.Update();
      publisher.Publish(learner);
      log.Updated(learner, u, trainer.max_steps);
      learner.ResetEpisodeStats();
      if (learner.samples() >= next_checkpoint) {
        if (leader) SaveCheckpoint(store, learner, config, log, "saved");
        next_checkpoint += trainer.checkpoint_interval;
      }
    }
    publisher.RepublishWhenDue();
  }
  return stopped;
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

int RunLearner(const TrainerConfig& trainer, const LearnerProcessConfig& config,
               const Endpoints& endpoints, const std::atomic<bool>& stop) {
  at::set_num_threads(trainer.threads);
  const double sgemm_gflops = blas::SgemmGflops();
  // Past a file size limit (RLIMIT_FSIZE) a write fails with EFBIG instead of killing us: a
  // checkpoint that does not fit is a logged failure, not a crash.
  std::signal(SIGXFSZ, SIG_IGN);
  CheckpointStore store(config.run_dir, trainer.keep_checkpoints);
  zmq::context_t context(1);
  std::unique_ptr<ReplicaGroup> group;
  if (config.replica.replicas > 1) {
    group = JoinReplicas(context, config, endpoints, stop);
    if (!group) return 0;  // stopped before the group formed: nothing trained, nothing to save
  }
  const int rank = group ? group->rank() : 0;
  const bool leader = rank == 0;  // publishes snapshots, writes checkpoints and the CSV
  torch::manual_seed(trainer.seed + static_cast<uint64_t>(rank));
  Learner learner(trainer, config.observation_size, config.action_size, group.get());
  learner.SetFigureNames(config.figure_names);
  if (leader) Restore(learner, store, context, config, endpoints);
  learner.SyncFromRankZero();  // the others take rank 0's state

  MetricsEndpoint endpoint("learner", config.metrics_bind, config.metrics_port, config.run_id);
  TrainingLog log(endpoint, config.run_dir, config.label, leader, learner, config.reward_terms);
  const double raw_gflops = MeasureRawGflops(trainer, config, learner);
  std::fprintf(stderr,
               "learner: %s; sgemm %.0f GFLOP/s on one thread, this network's fwd+bwd+Adam %.0f\n",
               blas::Summary(false).c_str(), sgemm_gflops, raw_gflops);
  log.CompareUpdatesWith(sgemm_gflops, raw_gflops);

  SegmentIntake intake(context, config, endpoints, learner, log);
  SnapshotPublisher publisher(context, config, endpoints, leader);
  publisher.Publish(learner);
  if (leader) WriteRunConfig(config);

  const bool stopped = Train(trainer, config, stop, leader, learner, store, log, intake, publisher);
  if (leader && !SaveCheckpoint(store, learner, config, log,
                                stopped ? "final (stopped)" : "final (max_steps reached)")) {
    return 1;
  }
  return 0;
}

}  // namespace ragdoll::learner
