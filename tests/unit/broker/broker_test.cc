#include "broker/broker.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <map>
#include <random>
#include <thread>

namespace ragdoll::broker {
namespace {

// The broker in this process on loopback ports, driven one poll at a time; with `curve`, a
// CURVE server whose keys folder holds one actor's and one learner's public key.
class BrokerTest : public ::testing::Test {
 protected:
  explicit BrokerTest(bool curve = false, int high_water_mark = Endpoints{}.high_water_mark) {
    config_.endpoints.high_water_mark = high_water_mark;
    if (curve) {
      keys_ =
          std::filesystem::temp_directory_path() / ("broker_test_keys_" + std::to_string(getpid()));
      std::filesystem::remove_all(keys_);
      for (const char* role : {"broker", "actor", "learner"}) {
        const KeyPaths paths = KeyPathsOf(keys_.string(), role, role);
        SaveCertificate(NewCertificate(role, role), paths.public_key, paths.secret_key);
      }
      config_.endpoints.curve = LoadCurve(keys_.string(), "broker");
      config_.keys_dir = keys_.string();
    }
    config_.endpoints.host = "127.0.0.1";
    config_.endpoints.bind = "127.0.0.1";
    config_.endpoints.max_message_bytes = 1 << 20;
    // Free ports: try random ones until the broker can bind all five.
    std::mt19937 rng(std::random_device{}());
    for (int attempt = 0; attempt < 20 && !broker_; ++attempt) {
      int base = 20000 + static_cast<int>(rng() % 20000);
      config_.endpoints.trajectory_port = base;
      config_.endpoints.control_port = base + 1;
      config_.endpoints.snapshot_port = base + 2;
      config_.endpoints.learner_port = base + 3;
      config_.endpoints.learner_snapshot_port = base + 4;
      try {
        broker_ = std::make_unique<Broker>(context_, config_, "run", &metrics_);
      } catch (const zmq::error_t&) {
        broker_.reset();
      }
    }
    if (!broker_) throw std::runtime_error("no free ports for the broker");
  }
  ~BrokerTest() override {
    broker_.reset();
    if (!keys_.empty()) std::filesystem::remove_all(keys_);
  }
  // A client socket: plaintext, or CURVE with `curve`'s keys.
  zmq::socket_t Connect(zmq::socket_type type, int port, const Curve& curve = {}) {
    Endpoints e = config_.endpoints;
    e.curve = curve;
    zmq::socket_t s = MakeSocket(context_, type, e, 0);
    s.connect(config_.endpoints.Connect(port));
    return s;
  }
  // Polls until `done` or about a second has passed.
  template <typename F>
  bool PollUntil(F done) {
    for (int i = 0; i < 100 && !done(); ++i) broker_->PollOnce(10);
    return done();
  }
  bool Receive(zmq::socket_t& s, zmq::message_t* m) {
    for (int i = 0; i < 100; ++i) {
      broker_->PollOnce(10);
      if (s.recv(*m, zmq::recv_flags::dontwait)) return true;
    }
    return false;
  }

  // The value of one series of the broker's registry; -1 when absent.
  double Metric(const std::string& name, const prometheus::Labels& labels = {}) {
    for (const auto& family : metrics_.registry().Collect()) {
      if (family.name != name) continue;
      for (const auto& m : family.metric) {
        bool match = true;
        for (const auto& [key, value] : labels) {
          bool found = false;
          for (const auto& l : m.label) found |= l.name == key && l.value == value;
          match &= found;
        }
        if (match)
          return family.type == prometheus::MetricType::Counter ? m.counter.value : m.gauge.value;
      }
    }
    return -1;
  }

  std::filesystem::path keys_;
  MetricsEndpoint metrics_{"broker", "127.0.0.1", -1, "run"};
  zmq::context_t context_{1};
  BrokerConfig config_;
  std::unique_ptr<Broker> broker_;
};

TEST_F(BrokerTest, ForwardsSegmentsUnchangedAndCountsBadMessages) {
  zmq::socket_t actor = Connect(zmq::socket_type::push, config_.endpoints.trajectory_port);
  zmq::socket_t learner = Connect(zmq::socket_type::pull, config_.endpoints.learner_port);
  v1::TrajectorySegment segment;
  segment.set_actor_id("a");
  std::string good = wire::Pack(v1::KIND_TRAJECTORY, "run", "a", segment, 3);
  actor.send(zmq::buffer(std::string("\x02\x00\x00\x00junk", 8)), zmq::send_flags::none);
  actor.send(zmq::buffer(wire::Pack(v1::KIND_TRAJECTORY, "other-run", "a", segment)),
             zmq::send_flags::none);
  actor.send(zmq::buffer(wire::PackEmpty(v1::KIND_HEARTBEAT, "run", "a")), zmq::send_flags::none);
  actor.send(zmq::buffer(good), zmq::send_flags::none);
  zmq::message_t forwarded;
  ASSERT_TRUE(Receive(learner, &forwarded));
  EXPECT_EQ(forwarded.to_string(), good);  // byte for byte
  const BrokerCounters c = broker_->counters();
  EXPECT_EQ(c.forwarded, 1);
  EXPECT_EQ(c.forwarded_bytes, static_cast<int64_t>(good.size()));
  EXPECT_EQ(c.rejected[static_cast<int>(wire::Rejection::kMalformed)], 1);
  EXPECT_EQ(c.rejected[static_cast<int>(wire::Rejection::kRunId)], 1);
  EXPECT_EQ(c.rejected[static_cast<int>(wire::Rejection::kKind)], 1);
  EXPECT_EQ(c.Rejected(), 3);
  // The Prometheus series say the same, by socket and reason.
  EXPECT_EQ(Metric("ragdoll_broker_segments_forwarded_total"), 1);
  EXPECT_EQ(Metric("ragdoll_broker_forwarded_bytes_total"), static_cast<double>(good.size()));
  EXPECT_EQ(Metric("ragdoll_broker_messages_rejected_total",
                   {{"socket", "trajectories"}, {"reason", "malformed"}}),
            1);
  EXPECT_EQ(Metric("ragdoll_broker_messages_rejected_total",
                   {{"socket", "trajectories"}, {"reason", "run_id"}}),
            1);
  EXPECT_EQ(Metric("ragdoll_broker_messages_rejected_total",
                   {{"socket", "control"}, {"reason", "malformed"}}),
            0);
  EXPECT_GT(Metric("ragdoll_broker_received_bytes_total"), static_cast<double>(good.size()));
}

TEST_F(BrokerTest, ServesTheNewestSnapshotToLateJoinersAndTracksActors) {
  zmq::socket_t control = Connect(zmq::socket_type::dealer, config_.endpoints.control_port);
  auto ask = [&]() {
    v1::SnapshotRequest request;
    request.set_actor_id("late");
    control.send(zmq::buffer(wire::Pack(v1::KIND_SNAPSHOT_REQUEST, "run", "late", request)),
                 zmq::send_flags::none);
    zmq::message_t reply;
    EXPECT_TRUE(Receive(control, &reply));
    v1::Header h;
    size_t offset;
    EXPECT_TRUE(wire::ReadHeader(reply.data(), reply.size(), 1 << 20, &h, &offset).ok());
    return h;
  };
  EXPECT_EQ(ask().kind(), v1::KIND_NO_SNAPSHOT);  // nothing yet

  zmq::socket_t learner = Connect(zmq::socket_type::push, config_.endpoints.learner_snapshot_port);
  v1::PolicySnapshot snapshot;
  snapshot.set_version(7);
  learner.send(zmq::buffer(wire::Pack(v1::KIND_SNAPSHOT, "run", "learner", snapshot, 7)),
               zmq::send_flags::none);
  ASSERT_TRUE(PollUntil([&] { return broker_->snapshot_version() == 7; }));
  v1::Header h = ask();
  EXPECT_EQ(h.kind(), v1::KIND_SNAPSHOT);
  EXPECT_EQ(h.policy_version(), 7);
  EXPECT_EQ(broker_->counters().snapshot_requests, 2);
  EXPECT_EQ(broker_->ActorsAlive(), 1);  // the late joiner, seen through its requests
}

// Learner replicas find each other through the broker: it waits for `replicas` of them, gives
// rank 0 to the one with the newest checkpoint, and tells everyone where rank 0's store is.
TEST_F(BrokerTest, RanksAGroupOfLearnerReplicasByTheirNewestCheckpoint) {
  auto replica = [&](const std::string& id) {
    zmq::socket_t s = MakeSocket(context_, zmq::socket_type::dealer, config_.endpoints, 0);
    s.set(zmq::sockopt::routing_id, id);
    s.connect(config_.endpoints.Connect(config_.endpoints.control_port));
    return s;
  };
  auto hello = [](const std::string& id, int replicas, const std::string& address,
                  int64_t checkpoint) {
    v1::ReplicaHello h;
    h.set_replica_id(id);
    h.set_replicas(replicas);
    h.set_address(address);
    h.set_store_port(6000);
    h.set_checkpoint_samples(checkpoint);
    return wire::Pack(v1::KIND_REPLICA_HELLO, "run", id, h);
  };
  zmq::socket_t a = replica("a"), b = replica("b"), other = replica("other");
  a.send(zmq::buffer(hello("a", 2, "host-a", 100)), zmq::send_flags::none);
  // A replica expecting another group size does not complete this group.
  other.send(zmq::buffer(hello("other", 3, "host-o", 900)), zmq::send_flags::none);
  zmq::message_t m;
  EXPECT_FALSE(Receive(a, &m));
  b.send(zmq::buffer(hello("b", 2, "host-b", 500)), zmq::send_flags::none);
  std::map<std::string, v1::ReplicaAssignment> placed;
  for (auto* s : {&a, &b}) {
    ASSERT_TRUE(Receive(*s, &m));
    v1::Header header;
    v1::ReplicaAssignment assignment;
    ASSERT_TRUE(wire::ReadMessage(m.data(), m.size(), 1 << 20, &header, &assignment).ok());
    EXPECT_EQ(header.kind(), v1::KIND_REPLICA_ASSIGNMENT);
    placed[s == &a ? "a" : "b"] = assignment;
  }
  EXPECT_EQ(placed["b"].rank(), 0);  // the newer checkpoint
  EXPECT_EQ(placed["a"].rank(), 1);
  for (const auto& [id, assignment] : placed) {
    EXPECT_EQ(assignment.replicas(), 2);
    EXPECT_EQ(assignment.store_host(), "host-b");
    EXPECT_EQ(assignment.store_port(), 6000);
    EXPECT_EQ(assignment.group(), 1);
  }
  EXPECT_FALSE(Receive(other, &m));
  EXPECT_EQ(Metric("ragdoll_broker_learner_groups_total"), 1);
  EXPECT_EQ(Metric("ragdoll_broker_learner_replicas"), 2);
  EXPECT_EQ(broker_->ActorsAlive(), 0);  // replicas are not actors

  // An impossible request is counted and dropped.
  other.send(zmq::buffer(hello("other", 0, "host-o", 0)), zmq::send_flags::none);
  EXPECT_TRUE(PollUntil([&] { return broker_->counters().Rejected() == 1; }));
}

// A learner slower than the actors: with queues of 2 messages a side, the broker stops reading
// segments while the learner's queue is full (the actors' queues fill and they wait) instead of
// reading a burst it cannot pass on. Every segment arrives, none is dropped.
class SlowLearnerBrokerTest : public BrokerTest {
 protected:
  SlowLearnerBrokerTest() : BrokerTest(false, 2) {}
};

TEST_F(SlowLearnerBrokerTest, PassesEverySegmentWhenTheLearnerIsTheBottleneck) {
  zmq::socket_t actor = Connect(zmq::socket_type::push, config_.endpoints.trajectory_port);
  zmq::socket_t learner = Connect(zmq::socket_type::pull, config_.endpoints.learner_port);
  v1::TrajectorySegment segment;
  segment.set_actor_id("a");
  // 256 kB each, so that the kernel's loopback buffers hold only a few and the queues do fill.
  segment.mutable_observations()->set_dtype(v1::Tensor::DTYPE_FLOAT32);
  segment.mutable_observations()->set_data(std::string(256 << 10, '\0'));
  const std::string good = wire::Pack(v1::KIND_TRAJECTORY, "run", "a", segment, 3);
  constexpr int kSegments = 200;
  int sent = 0, received = 0, actor_waited = 0;
  for (int i = 0; i < 40000 && received < kSegments; ++i) {
    if (sent < kSegments) {
      if (actor.send(zmq::buffer(good), zmq::send_flags::dontwait)) {
        ++sent;
      } else {
        ++actor_waited;  // the actor's own queue is full: the broker is holding back
      }
    }
    broker_->PollOnce(1);
    zmq::message_t m;
    if (i % 8 == 0 && learner.recv(m, zmq::recv_flags::dontwait)) {
      EXPECT_EQ(m.size(), good.size());
      ++received;
    }
  }
  EXPECT_EQ(sent, kSegments);
  EXPECT_EQ(received, kSegments);
  EXPECT_GT(actor_waited, 0);  // the learner was the bottleneck, as meant
  const BrokerCounters c = broker_->counters();
  EXPECT_EQ(c.forwarded, kSegments);
  EXPECT_EQ(c.unforwarded, 0);
  EXPECT_EQ(Metric("ragdoll_broker_segments_unforwarded_total"), 0);
}

class CurveBrokerTest : public BrokerTest {
 protected:
  CurveBrokerTest() : BrokerTest(true) {}
  Curve Keys(const std::string& role) { return LoadCurve(keys_.string(), role); }
  // Keys of a pair the broker has never seen.
  Curve Stranger() {
    Curve c = Keys("actor");
    Certificate fresh = NewCertificate("stranger", "actor");
    c.public_key = fresh.public_key;
    c.secret_key = fresh.secret_key;
    return c;
  }
  double Refused(const char* reason) {
    return Metric("ragdoll_broker_connections_refused_total", {{"reason", reason}});
  }
  // Polls for about `seconds`.
  void PollFor(double seconds) {
    for (int i = 0; i < seconds * 100; ++i) broker_->PollOnce(10);
  }
};

TEST_F(CurveBrokerTest, ForwardsOnlyFromKeysOfTheRightRoleAndCountsEveryRefusal) {
  v1::TrajectorySegment segment;
  segment.set_actor_id("a");
  auto segment_from = [&](const std::string& who) {
    return wire::Pack(v1::KIND_TRAJECTORY, "run", who, segment, 3);
  };
  zmq::socket_t learner =
      Connect(zmq::socket_type::pull, config_.endpoints.learner_port, Keys("learner"));
  zmq::socket_t actor =
      Connect(zmq::socket_type::push, config_.endpoints.trajectory_port, Keys("actor"));
  actor.send(zmq::buffer(segment_from("actor")), zmq::send_flags::none);
  zmq::message_t m;
  ASSERT_TRUE(Receive(learner, &m));
  EXPECT_EQ(m.to_string(), segment_from("actor"));

  // Intruders: a key the broker does not know, a plaintext client, a client that trusts another
  // broker key, and the learner's key on an actor's socket. Each sends, none gets a message in.
  Curve wrong_server = Keys("actor");
  wrong_server.server_key = NewCertificate("impostor", "broker").public_key;
  std::vector<zmq::socket_t> intruders;
  intruders.push_back(
      Connect(zmq::socket_type::push, config_.endpoints.trajectory_port, Stranger()));
  intruders.push_back(Connect(zmq::socket_type::push, config_.endpoints.trajectory_port));
  intruders.push_back(
      Connect(zmq::socket_type::push, config_.endpoints.trajectory_port, wrong_server));
  intruders.push_back(
      Connect(zmq::socket_type::push, config_.endpoints.trajectory_port, Keys("learner")));
  for (auto& s : intruders)
    s.send(zmq::buffer(segment_from("intruder")), zmq::send_flags::dontwait);
  PollFor(1.5);
  EXPECT_FALSE(learner.recv(m, zmq::recv_flags::dontwait));
  EXPECT_EQ(broker_->counters().forwarded, 1);
  EXPECT_EQ(broker_->counters().Rejected(), 0);  // refused before any message arrives
  EXPECT_GE(Refused("unknown_key"), 1);
  EXPECT_GE(Refused("not_curve"), 1);
  EXPECT_GE(Refused("bad_handshake"), 1);
  EXPECT_GE(Refused("wrong_role"), 1);
  // An actor's key cannot take the learner's segments either.
  zmq::socket_t thief =
      Connect(zmq::socket_type::pull, config_.endpoints.learner_port, Keys("actor"));
  const double wrong_role = Refused("wrong_role");
  PollFor(0.5);
  EXPECT_GT(Refused("wrong_role"), wrong_role);
  actor.send(zmq::buffer(segment_from("actor")), zmq::send_flags::none);
  ASSERT_TRUE(Receive(learner, &m));
  EXPECT_FALSE(thief.recv(m, zmq::recv_flags::dontwait));
  EXPECT_EQ(Metric("ragdoll_broker_connections_accepted_total", {{"role", "actor"}}), 1);
  EXPECT_EQ(Metric("ragdoll_broker_connections_accepted_total", {{"role", "learner"}}), 1);
}

TEST_F(CurveBrokerTest, AcceptsAKeyAddedToTheFolderWhileRunning) {
  Certificate late = NewCertificate("late", "actor");
  Curve curve = Keys("actor");
  curve.public_key = late.public_key;
  curve.secret_key = late.secret_key;
  zmq::socket_t learner =
      Connect(zmq::socket_type::pull, config_.endpoints.learner_port, Keys("learner"));
  {
    zmq::socket_t early = Connect(zmq::socket_type::push, config_.endpoints.trajectory_port, curve);
    PollFor(0.5);
    EXPECT_GE(Refused("unknown_key"), 1);
  }
  // keygen's layout: the public certificate lands in actors/; the broker re-reads the folder.
  std::this_thread::sleep_for(std::chrono::milliseconds(1100));
  SaveCertificate(late, KeyPathsOf(keys_.string(), "late", "actor").public_key, "");
  zmq::socket_t actor = Connect(zmq::socket_type::push, config_.endpoints.trajectory_port, curve);
  v1::TrajectorySegment segment;
  actor.send(zmq::buffer(wire::Pack(v1::KIND_TRAJECTORY, "run", "late", segment, 1)),
             zmq::send_flags::none);
  zmq::message_t m;
  EXPECT_TRUE(Receive(learner, &m));
}

TEST_F(CurveBrokerTest, OnlyALearnersKeyMayJoinALearnerGroup) {
  auto ask = [&](const Curve& keys, const std::string& id) {
    zmq::socket_t s = Connect(zmq::socket_type::dealer, config_.endpoints.control_port, keys);
    v1::ReplicaHello h;
    h.set_replica_id(id);
    h.set_replicas(1);
    h.set_address("host");
    h.set_store_port(6000);
    s.send(zmq::buffer(wire::Pack(v1::KIND_REPLICA_HELLO, "run", id, h)), zmq::send_flags::none);
    zmq::message_t m;
    return Receive(s, &m);
  };
  EXPECT_FALSE(ask(Keys("actor"), "posing-as-learner"));
  EXPECT_EQ(broker_->counters().rejected[static_cast<int>(wire::Rejection::kKind)], 1);
  EXPECT_TRUE(ask(Keys("learner"), "learner"));
  EXPECT_EQ(broker_->replica_groups(), 1);
}

}  // namespace
}  // namespace ragdoll::broker
