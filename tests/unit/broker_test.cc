#include "broker/broker.h"

#include <gtest/gtest.h>

#include <map>
#include <random>

namespace ragdoll::broker {
namespace {

// The broker in this process on loopback ports, driven one poll at a time.
class BrokerTest : public ::testing::Test {
 protected:
  BrokerTest() {
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
  zmq::socket_t Connect(zmq::socket_type type, int port) {
    zmq::socket_t s = MakeSocket(context_, type, config_.endpoints, 0);
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

}  // namespace
}  // namespace ragdoll::broker
