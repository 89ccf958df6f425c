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
  explicit ActorMetrics(MetricsEndpoint& m)
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
  }
  prometheus::Counter &samples, &segments, &sent_bytes, &episodes;
  prometheus::Gauge& version;
  prometheus::Counter &swaps, &rejected, &reconnects;
  prometheus::Gauge &connected, &environments;
  prometheus::Counter& idle_seconds;
};

}  // namespace

int RunActor(const sim::EnvConfig& env, const ActorConfig& config, const Endpoints& endpoints,
             const std::atomic<bool>& stop) {
  SetPolicyThreads(config.threads);
  std::fprintf(stderr, "%s: %s\n", config.actor_id.c_str(), blas::Summary(true).c_str());
  RolloutWorker worker(env, config.environments, config.time_horizon, config.seed, config.actor_id);
  MetricsEndpoint endpoint(config.actor_id, config.metrics_bind, config.metrics_port, config.run_id,
                           {{"actor", config.actor_id}});
  ActorMetrics metrics(endpoint);
  metrics.environments.Set(config.environments);
  zmq::context_t context(1);
  zmq::socket_t push = MakeSocket(context, zmq::socket_type::push, endpoints);
  ConnectionMonitor monitor(push, config.actor_id + "-push", "actor");
  zmq::socket_t control = MakeSocket(context, zmq::socket_type::dealer, endpoints);
  zmq::socket_t snapshots = MakeSocket(context, zmq::socket_type::sub, endpoints, 0);
  control.set(zmq::sockopt::routing_id, config.actor_id);
  snapshots.set(zmq::sockopt::conflate, 1);  // keep only the newest snapshot
  snapshots.set(zmq::sockopt::subscribe, "");
  push.connect(endpoints.Connect(endpoints.trajectory_port));
  control.connect(endpoints.Connect(endpoints.control_port));
  snapshots.connect(endpoints.Connect(endpoints.snapshot_port));

  v1::Hello hello;
  hello.set_actor_id(config.actor_id);
  hello.set_environments(config.environments);
  std::string hello_message = wire::Pack(v1::KIND_HELLO, config.run_id, config.actor_id, hello);
  Send(control, zmq::buffer(hello_message), zmq::send_flags::dontwait);

  int64_t rejected_snapshots = 0;
  // Installs a snapshot message if it is valid and for this run; returns true if installed.
  auto install = [&](const zmq::message_t& message) {
    v1::Header header;
    v1::PolicySnapshot snapshot;
    wire::Verdict v = wire::ReadMessage(message.data(), message.size(), endpoints.max_message_bytes,
                                        &header, &snapshot);
    if (v.ok() && header.kind() != v1::KIND_SNAPSHOT) return false;  // e.g. "no snapshot yet"
    if (v.ok()) v = wire::CheckSnapshot(snapshot);
    if (v.ok() && !config.run_id.empty() && header.run_id() != config.run_id) {
      v = {wire::Rejection::kRunId, "snapshot of run " + header.run_id()};
    }
    if (!v.ok()) {
      metrics.rejected.Increment();
      if (rejected_snapshots++ % 100 == 0) {
        std::fprintf(stderr, "%s: dropped a snapshot (%s): %s\n", config.actor_id.c_str(),
                     wire::RejectionName(v.rejection), v.detail.c_str());
      }
      return false;
    }
    if (snapshot.version() == worker.policy_version()) return false;
    worker.SetPolicy(snapshot);
    metrics.swaps.Increment();
    metrics.version.Set(static_cast<double>(snapshot.version()));
    return true;
  };

  // Wait for the first snapshot: ask the broker, back off up to 5 s, say so in the log.
  const auto started = Clock::now();
  double backoff = 0.25;
  int attempts = 0;
  while (!stop.load() && !worker.has_policy()) {
    v1::SnapshotRequest request;
    request.set_actor_id(config.actor_id);
    request.set_have_version(-1);
    std::string message =
        wire::Pack(v1::KIND_SNAPSHOT_REQUEST, config.run_id, config.actor_id, request);
    Send(control, zmq::buffer(message), zmq::send_flags::dontwait);
    auto asked = Clock::now();
    while (!stop.load() && !worker.has_policy() && Since(asked) < backoff) {
      zmq::message_t reply;
      if (Receive(control, reply)) install(reply);
      zmq::message_t published;
      if (Receive(snapshots, published, zmq::recv_flags::dontwait)) install(published);
      monitor.Poll();  // a refused handshake is said in the log
    }
    if (!worker.has_policy() && (attempts++ == 0 || backoff >= 5.0)) {
      std::fprintf(stderr,
                   "%s: waiting for the first policy snapshot from %s (retrying every %.1f s)\n",
                   config.actor_id.c_str(), endpoints.Connect(endpoints.control_port).c_str(),
                   std::min(backoff * 2, 5.0));
    }
    backoff = std::min(backoff * 2, 5.0);
  }
  if (worker.has_policy()) {
    std::fprintf(stderr, "%s: running %d environments with policy v%lld\n", config.actor_id.c_str(),
                 config.environments, static_cast<long long>(worker.policy_version()));
  }

  double idle_seconds = Since(started);
  metrics.idle_seconds.Increment(idle_seconds);
  auto last_heartbeat = Clock::now();
  int64_t dropped_segments = 0;
  while (!stop.load()) {
    std::vector<v1::TrajectorySegment> segments = worker.Collect();
    metrics.samples.Increment(static_cast<double>(config.environments) * config.time_horizon);
    for (const auto& segment : segments) {
      metrics.episodes.Increment(segment.episodes_size());
      std::string message = wire::Pack(v1::KIND_TRAJECTORY, config.run_id, config.actor_id, segment,
                                       segment.policy_version());
      // Blocks (1 s at a time) while the broker's queue is full: backpressure from a busy
      // learner. Segments that cannot leave before a stop are dropped.
      bool sent = false;
      const auto send_start = Clock::now();
      while (!stop.load() && !sent) {
        sent = Send(push, zmq::buffer(message));
      }
      const double waited = Since(send_start);
      idle_seconds += waited;
      metrics.idle_seconds.Increment(waited);
      if (sent) {
        metrics.segments.Increment();
        metrics.sent_bytes.Increment(static_cast<double>(message.size()));
      } else {
        ++dropped_segments;
      }
    }
    monitor.Poll();
    AdvanceTo(metrics.reconnects,
              static_cast<double>(std::max<int64_t>(monitor.connects() - 1, 0)));
    metrics.connected.Set(monitor.connected() ? 1 : 0);
    // Only between segments: take the newest published snapshot, if any.
    zmq::message_t published;
    if (Receive(snapshots, published, zmq::recv_flags::dontwait)) install(published);
    zmq::message_t reply;
    while (Receive(control, reply, zmq::recv_flags::dontwait)) install(reply);
    if (Since(last_heartbeat) >= config.heartbeat_interval) {
      last_heartbeat = Clock::now();
      v1::Heartbeat beat;
      beat.set_actor_id(config.actor_id);
      beat.set_policy_version(worker.policy_version());
      beat.set_samples(worker.samples());
      std::string message = wire::Pack(v1::KIND_HEARTBEAT, config.run_id, config.actor_id, beat);
      Send(control, zmq::buffer(message), zmq::send_flags::dontwait);
    }
  }
  std::fprintf(stderr,
               "%s: stopped after %lld samples (%lld segments dropped at shutdown); idle %.1f %% "
               "of %.0f s\n",
               config.actor_id.c_str(), static_cast<long long>(worker.samples()),
               static_cast<long long>(dropped_segments), 100 * idle_seconds / Since(started),
               Since(started));
  return 0;
}

}  // namespace ragdoll::actor
