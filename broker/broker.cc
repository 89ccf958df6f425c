#include "broker/broker.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>

namespace ragdoll::broker {

int64_t BrokerCounters::Rejected() const {
  int64_t total = 0;
  for (int64_t r : rejected) total += r;
  return total;
}

// The broker's Prometheus series: the one record of what it did (counters() reads them).
struct Broker::Metrics {
  explicit Metrics(MetricsEndpoint& m)
      : forwarded(m.Counter("ragdoll_broker_segments_forwarded_total",
                            "Trajectory segments forwarded to the learner")),
        forwarded_bytes(m.Counter("ragdoll_broker_forwarded_bytes_total",
                                  "Bytes of trajectory segments forwarded to the learner")),
        unforwarded(m.Counter("ragdoll_broker_segments_unforwarded_total",
                              "Valid trajectory segments dropped because no learner could take "
                              "them at once")),
        received_bytes(m.Counter("ragdoll_broker_received_bytes_total",
                                 "Bytes received on every socket, dropped messages included")),
        snapshots_received(m.Counter("ragdoll_broker_snapshots_received_total",
                                     "Policy snapshots received from the learner")),
        snapshots_published(m.Counter("ragdoll_broker_snapshots_published_total",
                                      "Policy snapshots published to actors")),
        snapshot_requests(m.Counter("ragdoll_broker_snapshot_requests_total",
                                    "Snapshot requests served to joining actors")),
        heartbeats(m.Counter("ragdoll_broker_heartbeats_total", "Actor heartbeats received")),
        actors(
            m.Gauge("ragdoll_broker_actors_connected", "Actors heard from within actor_timeout")),
        snapshot_version(m.Gauge("ragdoll_broker_snapshot_version",
                                 "Policy version of the cached snapshot (-1: none yet)")),
        replicas(m.Gauge("ragdoll_broker_learner_replicas",
                         "Learner replicas in the newest group the broker formed")),
        replica_groups(m.Counter("ragdoll_broker_learner_groups_total",
                                 "Groups of learner replicas formed (a restarted group counts "
                                 "again)")) {
    snapshot_version.Set(-1);
    for (const char* socket : {"trajectories", "snapshots", "control"}) {
      for (int r = 1; r <= static_cast<int>(wire::Rejection::kRunId); ++r) {
        rejected[socket].push_back(&m.Counter(
            "ragdoll_broker_messages_rejected_total", "Messages dropped by the broker, by reason",
            {{"socket", socket},
             {"reason", wire::RejectionName(static_cast<wire::Rejection>(r))}}));
      }
    }
  }
  prometheus::Counter &forwarded, &forwarded_bytes, &unforwarded, &received_bytes,
      &snapshots_received, &snapshots_published, &snapshot_requests, &heartbeats;
  prometheus::Gauge &actors, &snapshot_version, &replicas;
  prometheus::Counter& replica_groups;
  std::map<std::string, std::vector<prometheus::Counter*>> rejected;  // [socket][reason - 1]
};

Broker::~Broker() = default;

Broker::Broker(zmq::context_t& context, const BrokerConfig& config, std::string run_id,
               MetricsEndpoint* metrics)
    : config_(config), run_id_(std::move(run_id)) {
  if (!metrics) {  // kept, not served
    own_metrics_ = std::make_unique<MetricsEndpoint>("broker", "", -1, run_id_);
    metrics = own_metrics_.get();
  }
  const Endpoints& e = config.endpoints;
  if (e.curve.enabled()) {
    authenticator_ = std::make_unique<Authenticator>(context, config.keys_dir, *metrics);
  }
  trajectories_in_ = MakeServerSocket(context, zmq::socket_type::pull, e, kActorDomain);
  trajectories_out_ = MakeServerSocket(context, zmq::socket_type::push, e, kLearnerDomain);
  control_ = MakeServerSocket(context, zmq::socket_type::router, e, kControlDomain);
  snapshots_in_ = MakeServerSocket(context, zmq::socket_type::pull, e, kLearnerDomain);
  snapshots_out_ = MakeServerSocket(context, zmq::socket_type::pub, e, kActorDomain);
  // A full snapshot must never be dropped for a slow subscriber's queue: conflation happens on
  // the subscriber side, so a small send queue per subscriber is enough.
  snapshots_out_.set(zmq::sockopt::sndhwm, 4);
  if (authenticator_) {
    authenticator_->Watch(trajectories_in_, "trajectories");
    authenticator_->Watch(trajectories_out_, "learner");
    authenticator_->Watch(control_, "control");
    authenticator_->Watch(snapshots_in_, "learner-snapshots");
    authenticator_->Watch(snapshots_out_, "snapshots");
  }
  trajectories_in_.bind(e.Bind(e.trajectory_port));
  control_.bind(e.Bind(e.control_port));
  snapshots_out_.bind(e.Bind(e.snapshot_port));
  trajectories_out_.bind(e.Bind(e.learner_port));
  snapshots_in_.bind(e.Bind(e.learner_snapshot_port));
  metrics_ = std::make_unique<Metrics>(*metrics);
}

void Broker::Reject(const wire::Verdict& verdict, const char* where) {
  const int r = static_cast<int>(verdict.rejection);
  prometheus::Counter& counter = *metrics_->rejected.at(where).at(r - 1);
  counter.Increment();
  auto now = Clock::now();
  if (now - last_logged_[r] > std::chrono::seconds(60)) {
    last_logged_[r] = now;
    std::fprintf(stderr, "broker: dropped a message on %s (%s): %s [%lld so far]\n", where,
                 wire::RejectionName(verdict.rejection), verdict.detail.c_str(),
                 static_cast<long long>(counter.Value()));
  }
}

bool Broker::CheckRun(const v1::Header& header, const char* where) {
  if (run_id_.empty() || header.run_id() == run_id_) return true;
  Reject({wire::Rejection::kRunId, "run '" + header.run_id() + "', expected '" + run_id_ + "'"},
         where);
  return false;
}

void Broker::HandleTrajectory(zmq::message_t& message) {
  v1::Header header;
  size_t offset = 0;
  wire::Verdict v = wire::ReadHeader(message.data(), message.size(),
                                     config_.endpoints.max_message_bytes, &header, &offset);
  if (v.ok() && header.kind() != v1::KIND_TRAJECTORY) {
    v = {wire::Rejection::kKind, "expected a trajectory segment"};
  }
  if (!v.ok()) return Reject(v, "trajectories");
  if (!CheckRun(header, "trajectories")) return;
  last_seen_[header.sender()] = Clock::now();
  size_t bytes = message.size();
  // Forwarded as received: the broker never decodes tensors.
  // PollOnce reads a segment only when the learner can take one, so this fails only if every
  // learner's queue filled in between (a replica leaving): counted, never silent.
  if (trajectories_out_.send(message, zmq::send_flags::dontwait)) {
    metrics_->forwarded.Increment();
    metrics_->forwarded_bytes.Increment(static_cast<double>(bytes));
  } else {
    metrics_->unforwarded.Increment();
  }
}

void Broker::HandleSnapshot(zmq::message_t& message) {
  v1::Header header;
  size_t offset = 0;
  wire::Verdict v = wire::ReadHeader(message.data(), message.size(),
                                     config_.endpoints.max_message_bytes, &header, &offset);
  if (v.ok() && header.kind() != v1::KIND_SNAPSHOT) {
    v = {wire::Rejection::kKind, "expected a policy snapshot"};
  }
  if (!v.ok()) return Reject(v, "snapshots");
  if (!CheckRun(header, "snapshots")) return;
  metrics_->snapshots_received.Increment();
  metrics_->snapshot_version.Set(static_cast<double>(header.policy_version()));
  // The learner owns training state: whatever it sends is the newest, even a lower version
  // after it resumed from an older checkpoint.
  bool changed = header.policy_version() != snapshot_version_;
  snapshot_.assign(static_cast<const char*>(message.data()), message.size());
  snapshot_version_ = header.policy_version();
  if (changed || static_cast<int64_t>(metrics_->snapshots_received.Value()) % 8 == 0) {
    snapshots_out_.send(zmq::buffer(snapshot_), zmq::send_flags::dontwait);
    metrics_->snapshots_published.Increment();
  }
}

void Broker::HandleControl(zmq::message_t& identity, zmq::message_t& message) {
  v1::Header header;
  size_t offset = 0;
  wire::Verdict v = wire::ReadHeader(message.data(), message.size(),
                                     config_.endpoints.max_message_bytes, &header, &offset);
  if (!v.ok()) return Reject(v, "control");
  if (!CheckRun(header, "control")) return;
  // Under CURVE each kind comes from its role's keys only: a learner's key does not pose as an
  // actor (hello, heartbeats) nor an actor's key join a learner group. A snapshot request may
  // come from either: a resuming learner asks which version the actors run.
  const bool from_learner = header.kind() == v1::KIND_REPLICA_HELLO;
  if (authenticator_ && header.kind() != v1::KIND_SNAPSHOT_REQUEST &&
      Authenticator::RoleOf(message) != (from_learner ? kLearnerDomain : kActorDomain)) {
    return Reject(
        {wire::Rejection::kKind, std::string(from_learner ? "a learner's" : "an actor's") +
                                     " message from a key of the other role"},
        "control");
  }
  if (header.kind() == v1::KIND_REPLICA_HELLO) {
    v1::ReplicaHello hello;
    if (!hello.ParseFromArray(static_cast<const char*>(message.data()) + offset,
                              static_cast<int>(message.size() - offset))) {
      return Reject({wire::Rejection::kMalformed, "replica hello does not parse"}, "control");
    }
    if (hello.replicas() < 1 || hello.replicas() > 4096 || hello.store_port() <= 0 ||
        hello.store_port() > 65535 || hello.address().empty() || hello.replica_id().empty()) {
      return Reject({wire::Rejection::kMalformed, "replica hello with an impossible group"},
                    "control");
    }
    return HandleReplicaHello(identity.to_string(), hello);
  }
  // A learner asking for the snapshot is not an actor.
  if (!authenticator_ || Authenticator::RoleOf(message) == kActorDomain) {
    last_seen_[header.sender()] = Clock::now();
  }
  switch (header.kind()) {
    case v1::KIND_HELLO:
      std::fprintf(stderr, "broker: actor %s connected\n", header.sender().c_str());
      break;
    case v1::KIND_HEARTBEAT:
      metrics_->heartbeats.Increment();
      break;
    case v1::KIND_SNAPSHOT_REQUEST: {
      metrics_->snapshot_requests.Increment();
      control_.send(identity, zmq::send_flags::sndmore | zmq::send_flags::dontwait);
      if (snapshot_.empty()) {
        std::string none = wire::PackEmpty(v1::KIND_NO_SNAPSHOT, run_id_, "broker");
        control_.send(zmq::buffer(none), zmq::send_flags::dontwait);
      } else {
        control_.send(zmq::buffer(snapshot_), zmq::send_flags::dontwait);
      }
      break;
    }
    default:
      Reject({wire::Rejection::kKind, "unexpected kind on the control socket"}, "control");
  }
}

void Broker::HandleReplicaHello(const std::string& identity, const v1::ReplicaHello& hello) {
  const auto now = Clock::now();
  auto [it, fresh] = pending_replicas_.try_emplace(hello.replica_id());
  if (fresh) {
    it->second.first_asked = now;
    std::fprintf(stderr, "broker: learner replica %s asks for a group of %d\n",
                 hello.replica_id().c_str(), hello.replicas());
  }
  it->second.identity = identity;
  it->second.hello = hello;
  it->second.last_asked = now;
  // Forget replicas that stopped asking, and gather the ones that agree on the group size.
  std::vector<const PendingReplica*> group;
  for (auto p = pending_replicas_.begin(); p != pending_replicas_.end();) {
    if (now - p->second.last_asked > std::chrono::seconds(3)) {
      p = pending_replicas_.erase(p);
      continue;
    }
    if (p->second.hello.replicas() == hello.replicas()) group.push_back(&p->second);
    ++p;
  }
  if (static_cast<int>(group.size()) < hello.replicas()) return;
  // Rank 0 holds the newest checkpoint; among equals, the first to ask.
  std::sort(group.begin(), group.end(), [](const PendingReplica* a, const PendingReplica* b) {
    if (a->hello.checkpoint_samples() != b->hello.checkpoint_samples()) {
      return a->hello.checkpoint_samples() > b->hello.checkpoint_samples();
    }
    return a->first_asked < b->first_asked;
  });
  group.resize(static_cast<size_t>(hello.replicas()));
  ++replica_groups_;
  metrics_->replica_groups.Increment();
  metrics_->replicas.Set(hello.replicas());
  const v1::ReplicaHello& zero = group[0]->hello;
  std::vector<std::string> placed;
  for (size_t rank = 0; rank < group.size(); ++rank) {
    v1::ReplicaAssignment a;
    a.set_rank(static_cast<int>(rank));
    a.set_replicas(hello.replicas());
    a.set_store_host(zero.address());
    a.set_store_port(zero.store_port());
    a.set_group(replica_groups_);
    const std::string reply = wire::Pack(v1::KIND_REPLICA_ASSIGNMENT, run_id_, "broker", a);
    control_.send(zmq::buffer(group[rank]->identity),
                  zmq::send_flags::sndmore | zmq::send_flags::dontwait);
    control_.send(zmq::buffer(reply), zmq::send_flags::dontwait);
    placed.push_back(group[rank]->hello.replica_id());
  }
  std::fprintf(stderr, "broker: learner group %lld of %d replicas: rank 0 %s (store %s:%d)\n",
               static_cast<long long>(replica_groups_), hello.replicas(), placed[0].c_str(),
               zero.address().c_str(), zero.store_port());
  for (const auto& id : placed) pending_replicas_.erase(id);
}

namespace {
// Whether a learner can take one more segment now (its queue has room).
bool CanSend(zmq::socket_t& socket) {
  return (socket.get(zmq::sockopt::events) & ZMQ_POLLOUT) != 0;
}
}  // namespace

void Broker::PollOnce(int timeout_ms) {
  // Read segments only while the learner can take them: a stalled or absent learner stalls the
  // actors (their send queues fill) instead of piling segments up here. Waiting on the inbound
  // socket meanwhile would wake this loop at once, over and over: wait for the learner instead.
  const bool learner_ready = CanSend(trajectories_out_);
  zmq::pollitem_t items[] = {
      {trajectories_in_.handle(), 0, static_cast<short>(learner_ready ? ZMQ_POLLIN : 0), 0},
      {control_.handle(), 0, ZMQ_POLLIN, 0},
      {snapshots_in_.handle(), 0, ZMQ_POLLIN, 0},
      {trajectories_out_.handle(), 0, static_cast<short>(learner_ready ? 0 : ZMQ_POLLOUT), 0},
      {authenticator_ ? authenticator_->socket().handle() : nullptr, 0,
       static_cast<short>(authenticator_ ? ZMQ_POLLIN : 0), 0},
  };
  try {
    zmq::poll(items, authenticator_ ? 5 : 4, std::chrono::milliseconds(timeout_ms));
  } catch (const zmq::error_t& e) {
    if (e.num() == EINTR) return;  // a signal: Run() checks its stop flag
    throw;
  }
  if (items[0].revents & ZMQ_POLLIN) {
    // A burst of up to 64, each segment read only while the learner can take it: one read that
    // a full queue then refused would be lost.
    for (int i = 0; i < 64 && CanSend(trajectories_out_); ++i) {
      zmq::message_t message;
      if (!trajectories_in_.recv(message, zmq::recv_flags::dontwait)) break;
      metrics_->received_bytes.Increment(static_cast<double>(message.size()));
      HandleTrajectory(message);
    }
  }
  if (items[1].revents & ZMQ_POLLIN) {
    for (int i = 0; i < 64; ++i) {
      zmq::message_t identity, message;
      if (!control_.recv(identity, zmq::recv_flags::dontwait)) break;
      if (!identity.more() || !control_.recv(message, zmq::recv_flags::dontwait)) {
        Reject({wire::Rejection::kMalformed, "control message without a body"}, "control");
        continue;
      }
      while (message.more()) {  // extra frames: drain and drop
        zmq::message_t extra;
        if (!control_.recv(extra, zmq::recv_flags::dontwait)) break;
        message.swap(extra);
      }
      metrics_->received_bytes.Increment(static_cast<double>(message.size()));
      HandleControl(identity, message);
    }
  }
  if (items[2].revents & ZMQ_POLLIN) {
    for (int i = 0; i < 16; ++i) {
      zmq::message_t message;
      if (!snapshots_in_.recv(message, zmq::recv_flags::dontwait)) break;
      metrics_->received_bytes.Increment(static_cast<double>(message.size()));
      HandleSnapshot(message);
    }
  }
  if (authenticator_ && (items[4].revents & ZMQ_POLLIN)) authenticator_->HandleRequests();
  if (Clock::now() - last_gauges_ > std::chrono::milliseconds(500)) {
    last_gauges_ = Clock::now();
    if (authenticator_) authenticator_->ReadWatches();
    metrics_->actors.Set(ActorsAlive());
  }
}

BrokerCounters Broker::counters() const {
  auto count = [](const prometheus::Counter& c) { return static_cast<int64_t>(c.Value()); };
  const Metrics& m = *metrics_;
  BrokerCounters c;
  c.forwarded = count(m.forwarded);
  c.forwarded_bytes = count(m.forwarded_bytes);
  c.unforwarded = count(m.unforwarded);
  c.snapshots_received = count(m.snapshots_received);
  c.snapshots_published = count(m.snapshots_published);
  c.snapshot_requests = count(m.snapshot_requests);
  c.heartbeats = count(m.heartbeats);
  for (const auto& [socket, reasons] : m.rejected) {
    for (size_t r = 0; r < reasons.size(); ++r) c.rejected[r + 1] += count(*reasons[r]);
  }
  return c;
}

int Broker::ActorsAlive() const {
  auto now = Clock::now();
  int alive = 0;
  for (const auto& [id, seen] : last_seen_) {
    if (id != "learner" &&
        std::chrono::duration<double>(now - seen).count() < config_.actor_timeout) {
      ++alive;
    }
  }
  return alive;
}

void Broker::Run(const std::atomic<bool>& stop, double log_seconds) {
  auto last_log = Clock::now();
  while (!stop.load()) {
    PollOnce(100);
    if (std::chrono::duration<double>(Clock::now() - last_log).count() > log_seconds) {
      last_log = Clock::now();
      const BrokerCounters c = counters();
      std::fprintf(stderr,
                   "broker: %lld segments forwarded (%.1f MB), %lld rejected, snapshot v%lld, "
                   "%d actors alive\n",
                   static_cast<long long>(c.forwarded), c.forwarded_bytes / 1e6,
                   static_cast<long long>(c.Rejected()), static_cast<long long>(snapshot_version_),
                   ActorsAlive());
    }
  }
}

}  // namespace ragdoll::broker
