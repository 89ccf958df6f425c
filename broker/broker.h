// The broker: one poll loop that forwards trajectory segments from actors to the learner
// without decoding them, caches the newest policy snapshot, publishes it to actors and serves it
// to late joiners, and tracks which actors are alive. It holds no training state: restarting it
// loses only messages in flight. Bad messages are counted and dropped, never fatal.
#pragma once

#include <zmq.hpp>

#include <array>
#include <atomic>
#include <chrono>
#include <map>
#include <memory>
#include <string>

#include "broker/authenticator.h"
#include "common/endpoints.h"
#include "common/metrics.h"
#include "common/wire.h"

namespace ragdoll::broker {

struct BrokerConfig {
  Endpoints endpoints;
  double actor_timeout = 10.0;  // seconds without a heartbeat before an actor counts as gone
  // With CURVE keys in endpoints.curve: the folder whose actors/ and learners/ hold the public
  // keys the broker accepts (re-read when they change).
  std::string keys_dir;
};

struct BrokerCounters {
  int64_t forwarded = 0;  // segments passed to the learner
  int64_t forwarded_bytes = 0;
  int64_t unforwarded = 0;  // valid segments no learner could take at once (dropped)
  int64_t snapshots_received = 0;
  int64_t snapshots_published = 0;
  int64_t snapshot_requests = 0;
  int64_t heartbeats = 0;
  std::array<int64_t, 9> rejected{};  // indexed by wire::Rejection
  int64_t Rejected() const;
};

class Broker {
 public:
  // Binds every socket (CURVE servers when endpoints.curve holds keys); throws zmq::error_t when
  // a port is taken, std::runtime_error for a bad key. Keeps its Prometheus series
  // in `metrics`' registry (which must outlive the broker), or in a registry of its own.
  Broker(zmq::context_t& context, const BrokerConfig& config, std::string run_id,
         MetricsEndpoint* metrics = nullptr);
  ~Broker();

  // Polls until `stop` is set, logging a summary every `log_seconds`.
  void Run(const std::atomic<bool>& stop, double log_seconds = 30);
  // One poll of at most `timeout_ms`; handles whatever arrived.
  void PollOnce(int timeout_ms);

  // What the broker did so far, read from its Prometheus series.
  BrokerCounters counters() const;
  int ActorsAlive() const;
  int64_t snapshot_version() const { return snapshot_version_; }
  int64_t replica_groups() const { return replica_groups_; }
  // The gatekeeper under CURVE; null in plaintext.
  const Authenticator* authenticator() const { return authenticator_.get(); }

 private:
  using Clock = std::chrono::steady_clock;
  void HandleTrajectory(zmq::message_t& message);
  void HandleSnapshot(zmq::message_t& message);
  void HandleControl(zmq::message_t& identity, zmq::message_t& message);
  // A learner replica's request: places it, and when `replicas` fresh requests agree, assigns
  // the ranks of a new group.
  void HandleReplicaHello(const std::string& identity, const v1::ReplicaHello& hello);
  // Counts a dropped message and logs at most once a minute per reason.
  void Reject(const wire::Verdict& verdict, const char* where);
  bool CheckRun(const v1::Header& header, const char* where);

  BrokerConfig config_;
  std::string run_id_;
  std::unique_ptr<MetricsEndpoint> own_metrics_;  // when the caller gave none
  zmq::socket_t trajectories_in_;                 // PULL from actors
  zmq::socket_t trajectories_out_;                // PUSH to the learner
  zmq::socket_t control_;        // ROUTER for actors' hello, heartbeats, snapshot requests
  zmq::socket_t snapshots_in_;   // PULL from the learner
  zmq::socket_t snapshots_out_;  // PUB to actors
  // Bound before the sockets (the constructor sees to it), destroyed before them: it watches them.
  std::unique_ptr<Authenticator> authenticator_;
  std::string snapshot_;  // the newest snapshot message, as received
  int64_t snapshot_version_ = -1;
  std::map<std::string, Clock::time_point> last_seen_;
  struct PendingReplica {
    std::string identity;  // the ROUTER identity to answer
    v1::ReplicaHello hello;
    Clock::time_point first_asked, last_asked;
  };
  std::map<std::string, PendingReplica> pending_replicas_;  // by replica_id
  int64_t replica_groups_ = 0;
  std::array<Clock::time_point, 9> last_logged_{};
  struct Metrics;
  std::unique_ptr<Metrics> metrics_;
  Clock::time_point last_gauges_{};
};

}  // namespace ragdoll::broker
