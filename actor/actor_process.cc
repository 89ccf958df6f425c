#include "actor/actor_process.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <thread>

#include "actor/rollout.h"
#include "common/blas.h"
#include "common/metrics.h"
#include "common/wire.h"

namespace ragdoll::actor {
namespace {

using Clock = std::chrono::steady_clock;

double Since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

struct ActorMetrics {
  ActorMetrics(MetricsEndpoint& m, int environment_count)
      : samples(m.Counter("ragdoll_actor_samples_total", "Environment steps simulated")),
        segments(m.Counter("ragdoll_actor_segments_sent_total", "Trajectory segments sent")),
        sent_bytes(m.Counter("ragdoll_actor_sent_bytes_total", "Bytes of segments sent")),
        episodes(m.Counter("ragdoll_actor_episodes_total", "Episodes finished")),
        version(m.Gauge("ragdoll_actor_snapshot_version",
                        "Version of the policy the actor runs (-1: none yet)")),
        swaps(m.Counter("ragdoll_actor_snapshot_swaps_total", "Policy snapshots installed")),
        rejected(m.Counter("ragdoll_actor_rejected_snapshots_total",
                           "Snapshot messages dropped as invalid or of another run")),
        reconnects(m.Counter("ragdoll_actor_reconnects_total",
                             "Reconnections to the broker after the first connection")),
        connected(m.Gauge("ragdoll_actor_connected",
                          "1 while the trajectory socket is connected to the broker")),
        environments(m.Gauge("ragdoll_actor_environments", "Environments stepped in lockstep")),
        idle_seconds(m.Counter("ragdoll_actor_idle_seconds_total",
                               "Wall time spent waiting: for the first snapshot, or for the "
                               "broker to take a segment (backpressure)")) {
    version.Set(-1);
    environments.Set(environment_count);
  }
  prometheus::Counter &samples, &segments, &sent_bytes, &episodes;
  prometheus::Gauge& version;
  prometheus::Counter &swaps, &rejected, &reconnects;
  prometheus::Gauge &connected, &environments;
  prometheus::Counter& idle_seconds;
};

// A running actor: the worker, its metrics and its sockets to the broker; RunActor's steps.
class Actor {
 public:
  Actor(const sim::EnvConfig& env, const ActorConfig& config, const Endpoints& endpoints,
        const std::atomic<bool>& stop);
  void SayHello();
  void WaitForFirstSnapshot();
  // Collects segments and sends them until a stop.
  void Stream();
  void ReportStop() const;

 private:
  // Installs a snapshot message if it is valid and for this run; returns true if installed.
  bool Install(const zmq::message_t& message);
  void SendSegment(const v1::TrajectorySegment& segment);
  void TakeSnapshots();
  void SendHeartbeat();

  const ActorConfig& config_;
  const Endpoints& endpoints_;
  const std::atomic<bool>& stop_;
  RolloutWorker worker_;
  MetricsEndpoint metrics_endpoint_;
  ActorMetrics metrics_;
  zmq::context_t context_{1};
  zmq::socket_t push_;
  ConnectionMonitor monitor_;
  zmq::socket_t control_;
  zmq::socket_t snapshots_;
  int64_t rejected_snapshots_ = 0;
  Clock::time_point started_;
  double idle_seconds_ = 0;
  int64_t dropped_segments_ = 0;
};

Actor::Actor(const sim::EnvConfig& env, const ActorConfig& config, const Endpoints& endpoints,
             const std::atomic<bool>& stop)
    : config_(config),
      endpoints_(endpoints),
      stop_(stop),
      worker_(env, config.environments, config.time_horizon, config.seed, config.actor_id),
      metrics_endpoint_(config.actor_id, config.metrics_bind, config.metrics_port, config.run_id,
                        {{"actor", config.actor_id}}),
      metrics_(metrics_endpoint_, config.environments),
      push_(MakeSocket(context_, zmq::socket_type::push, endpoints)),
      monitor_(push_, config.actor_id + "-push", "actor"),
      control_(MakeSocket(context_, zmq::socket_type::dealer, endpoints)),
      snapshots_(MakeSocket(context_, zmq::socket_type::sub, endpoints, 0)) {
  control_.set(zmq::sockopt::routing_id, config.actor_id);
  snapshots_.set(zmq::sockopt::conflate, 1);  // keep only the newest snapshot
  snapshots_.set(zmq::sockopt::subscribe, "");
  push_.connect(endpoints.Connect(endpoints.trajectory_port));
  control_.connect(endpoints.Connect(endpoints.control_port));
  snapshots_.connect(endpoints.Connect(endpoints.snapshot_port));
}

void Actor::SayHello() {
  v1::Hello hello;
  hello.set_actor_id(config_.actor_id);
  hello.set_environments(config_.environments);
  std::string hello_message = wire::Pack(v1::KIND_HELLO, config_.run_id, config_.actor_id, hello);
  Send(control_, zmq::buffer(hello_message), zmq::send_flags::dontwait);
}

bool Actor::Install(const zmq::message_t& message) {
  v1::Header header;
  v1::PolicySnapshot snapshot;
  wire::Verdict v = wire::ReadMessage(message.data(), message.size(), endpoints_.max_message_bytes,
                                      &header, &snapshot);
  if (v.ok() && header.kind() != v1::KIND_SNAPSHOT) return false;  // e.g. "no snapshot yet"
  if (v.ok()) v = wire::CheckSnapshot(snapshot);
  if (v.ok() && !config_.run_id.empty() && header.run_id() != config_.run_id) {
    v = {wire::Rejection::kRunId, "snapshot of run " + header.run_id()};
  }
  if (!v.ok()) {
    metrics_.rejected.Increment();
    if (rejected_snapshots_++ % 100 == 0) {
      std::fprintf(stderr, "%s: dropped a snapshot (%s): %s\n", config_.actor_id.c_str(),
                   wire::RejectionName(v.rejection), v.detail.c_str());
    }
    return false;
  }
  if (snapshot.version() == worker_.policy_version()) return false;
  worker_.SetPolicy(snapshot);
  metrics_.swaps.Increment();
  metrics_.version.Set(static_cast<double>(snapshot.version()));
  return true;
}

void Actor::WaitForFirstSnapshot() {
  // Wait for the first snapshot: ask the broker, back off up to 5 s, say so in the log.
  started_ = Clock::now();
  double backoff = 0.25;
  int attempts = 0;
  while (!stop_.load() && !worker_.has_policy()) {
    v1::SnapshotRequest request;
    request.set_actor_id(config_.actor_id);
    request.set_have_version(-1);
    std::string message =
        wire::Pack(v1::KIND_SNAPSHOT_REQUEST, config_.run_id, config_.actor_id, request);
    Send(control_, zmq::buffer(message), zmq::send_flags::dontwait);
    auto asked = Clock::now();
    while (!stop_.load() && !worker_.has_policy() && Since(asked) < backoff) {
      zmq::message_t reply;
      if (Receive(control_, reply)) Install(reply);
      zmq::message_t published;
      if (Receive(snapshots_, published, zmq::recv_flags::dontwait)) Install(published);
      monitor_.Poll();  // a refused handshake is said in the log
    }
    if (!worker_.has_policy() && (attempts++ == 0 || backoff >= 5.0)) {
      std::fprintf(stderr,
                   "%s: waiting for the first policy snapshot from %s (retrying every %.1f s)\n",
                   config_.actor_id.c_str(), endpoints_.Connect(endpoints_.control_port).c_str(),
                   std::min(backoff * 2, 5.0));
    }
    backoff = std::min(backoff * 2, 5.0);
  }
  if (worker_.has_policy()) {
    std::fprintf(stderr, "%s: running %d environments with policy v%lld\n",
                 config_.actor_id.c_str(), config_.environments,
                 static_cast<long long>(worker_.policy_version()));
  }
  idle_seconds_ = Since(started_);
  metrics_.idle_seconds.Increment(idle_seconds_);
}

void Actor::Stream() {
  auto last_heartbeat = Clock::now();
  while (!stop_.load()) {
    std::vector<v1::TrajectorySegment> segments = worker_.Collect();
    metrics_.samples.Increment(static_cast<double>(config_.environments) * config_.time_horizon);
    for (const auto& segment : segments) SendSegment(segment);
    monitor_.Poll();
    AdvanceTo(metrics_.reconnects,
              static_cast<double>(std::max<int64_t>(monitor_.connects() - 1, 0)));
    metrics_.connected.Set(monitor_.connected() ? 1 : 0);
    TakeSnapshots();
    if (Since(last_heartbeat) >= config_.heartbeat_interval) {
      last_heartbeat = Clock::now();
      SendHeartbeat();
    }
  }
}

void Actor::SendSegment(const v1::TrajectorySegment& segment) {
  metrics_.episodes.Increment(segment.episodes_size());
  std::string message = wire::Pack(v1::KIND_TRAJECTORY, config_.run_id, config_.actor_id, segment,
                                   segment.policy_version());
  // Blocks (1 s at a time) while the broker's queue is full: backpressure from a busy
  // learner. Segments that cannot leave before a stop are dropped.
  bool sent = false;
  const auto send_start = Clock::now();
  while (!stop_.load() && !sent) {
    sent = Send(push_, zmq::buffer(message));
  }
  const double waited = Since(send_start);
  idle_seconds_ += waited;
  metrics_.idle_seconds.Increment(waited);
  if (sent) {
    metrics_.segments.Increment();
    metrics_.sent_bytes.Increment(static_cast<double>(message.size()));
  } else {
    ++dropped_segments_;
  }
}

void Actor::TakeSnapshots() {
  // Only between segments: take the newest published snapshot, if any.
  zmq::message_t published;
  if (Receive(snapshots_, published, zmq::recv_flags::dontwait)) Install(published);
  zmq::message_t reply;
  while (Receive(control_, reply, zmq::recv_flags::dontwait)) Install(reply);
}

void Actor::SendHeartbeat() {
  v1::Heartbeat beat;
  beat.set_actor_id(config_.actor_id);
  beat.set_policy_version(worker_.policy_version());
  beat.set_samples(worker_.samples());
  std::string message = wire::Pack(v1::KIND_HEARTBEAT, config_.run_id, config_.actor_id, beat);
  Send(control_, zmq::buffer(message), zmq::send_flags::dontwait);
}

void Actor::ReportStop() const {
  std::fprintf(stderr,
               "%s: stopped after %lld samples (%lld segments dropped at shutdown); idle %.1f %% "
               "of %.0f s\n",
               config_.actor_id.c_str(), static_cast<long long>(worker_.samples()),
               static_cast<long long>(dropped_segments_), 100 * idle_seconds_ / Since(started_),
               Since(started_));
}

}  // namespace

int RunActor(const sim::EnvConfig& env, const ActorConfig& config, const Endpoints& endpoints,
             const std::atomic<bool>& stop) {
  SetPolicyThreads(config.threads);
  std::fprintf(stderr, "%s: %s\n", config.actor_id.c_str(), blas::Summary(true).c_str());
  Actor actor(env, config, endpoints, stop);
  actor.SayHello();
  actor.WaitForFirstSnapshot();
  actor.Stream();
  actor.ReportStop();
  return 0;
}

}  // namespace ragdoll::actor
