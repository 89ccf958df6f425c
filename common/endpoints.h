// Where the broker listens and how every role reaches it, plus the socket settings all roles
// share (high-water marks, linger, reconnect intervals).
#pragma once

#include <zmq.hpp>

#include <cstdint>
#include <string>

namespace ragdoll {

class ConfigSection;

struct Endpoints {
  std::string host = "127.0.0.1";    // where actors and the learner find the broker
  std::string bind = "*";            // the interface the broker listens on
  int trajectory_port = 5555;        // actors PUSH segments -> broker PULL
  int control_port = 5556;           // actors DEALER (hello, heartbeat, snapshot request) -> ROUTER
  int snapshot_port = 5557;          // broker PUB snapshots -> actors SUB (conflated)
  int learner_port = 5558;           // broker PUSH segments -> learner PULL
  int learner_snapshot_port = 5559;  // learner PUSH snapshots -> broker PULL
  int high_water_mark = 256;         // messages queued per socket before senders wait
  int64_t max_message_bytes = 64ll << 20;

  std::string Bind(int port) const { return "tcp://" + bind + ":" + std::to_string(port); }
  std::string Connect(int port) const { return "tcp://" + host + ":" + std::to_string(port); }
};

// Reads the `broker:` section's endpoint keys (the broker reads its other keys itself).
Endpoints ReadEndpoints(const ConfigSection& section);

// A socket with the project's settings: no linger on close (shutdown never hangs on unsent
// messages), bounded queues, reconnection every 100 ms up to 2 s, and a receive timeout so that
// loops can check their stop flag.
zmq::socket_t MakeSocket(zmq::context_t& context, zmq::socket_type type, const Endpoints& endpoints,
                         int receive_timeout_ms = 100);

// recv/send that treat a signal's interruption (EINTR) like a timeout: false, nothing moved.
// The caller's loop then checks its stop flag, which the signal handler has set.
bool Receive(zmq::socket_t& socket, zmq::message_t& message,
             zmq::recv_flags flags = zmq::recv_flags::none);
bool Send(zmq::socket_t& socket, zmq::const_buffer data,
          zmq::send_flags flags = zmq::send_flags::none);

}  // namespace ragdoll
