// Where the broker listens and how every role reaches it, plus the socket settings all roles
// share (high-water marks, linger, reconnect intervals).
#pragma once

#include <zmq.hpp>

#include <chrono>
#include <cstdint>
#include <string>

#include "common/keys.h"

namespace ragdoll {

class ConfigSection;

struct Endpoints {
  std::string host = "127.0.0.1";  // where actors and the learner find the broker
  // The interface the broker listens on. Unset in the config: the host itself when it is a
  // loopback address (everything on this machine), else every interface ("*").
  std::string bind = "*";
  int trajectory_port = 5555;        // actors PUSH segments -> broker PULL
  int control_port = 5556;           // actors DEALER (hello, heartbeat, snapshot request) -> ROUTER
  int snapshot_port = 5557;          // broker PUB snapshots -> actors SUB (conflated)
  int learner_port = 5558;           // broker PUSH segments -> learner PULL
  int learner_snapshot_port = 5559;  // learner PUSH snapshots -> broker PULL
  int high_water_mark = 256;         // messages queued per socket before senders wait
  int64_t max_message_bytes = 64ll << 20;
  Curve curve;  // this process's CURVE keys; none: plaintext

  std::string Bind(int port) const { return "tcp://" + bind + ":" + std::to_string(port); }
  std::string Connect(int port) const { return "tcp://" + host + ":" + std::to_string(port); }
};

// Reads the `broker:` section's endpoint keys (the broker reads its other keys itself).
Endpoints ReadEndpoints(const ConfigSection& section);

// A socket with the project's settings: no linger on close (shutdown never hangs on unsent
// messages), bounded queues, reconnection every 100 ms up to 2 s, and a receive timeout so that
// loops can check their stop flag. With CURVE keys it is a CURVE client of the broker.
zmq::socket_t MakeSocket(zmq::context_t& context, zmq::socket_type type, const Endpoints& endpoints,
                         int receive_timeout_ms = 100);
// The same settings for a socket the broker binds: with CURVE keys a CURVE server whose peers
// are authenticated by the ZAP handler under `zap_domain` (the role allowed on it).
zmq::socket_t MakeServerSocket(zmq::context_t& context, zmq::socket_type type,
                               const Endpoints& endpoints, const std::string& zap_domain);

// Throws std::runtime_error when the broker would listen beyond loopback in plaintext, unless
// `insecure`: anyone reaching the ports could push trajectories into training or read weights.
void CheckTransportSecurity(const Endpoints& endpoints, bool insecure);

// recv/send that treat a signal's interruption (EINTR) like a timeout: false, nothing moved.
// The caller's loop then checks its stop flag, which the signal handler has set.
bool Receive(zmq::socket_t& socket, zmq::message_t& message,
             zmq::recv_flags flags = zmq::recv_flags::none);
bool Send(zmq::socket_t& socket, zmq::const_buffer data,
          zmq::send_flags flags = zmq::send_flags::none);

// Watches a client socket's connection to the broker: counts connections (the first, then one
// per reconnection after a broker restart or network loss) and says in the log, at most every
// 30 s, why a handshake fails (a refused key, CURVE on one side only, another broker's key).
class ConnectionMonitor : public zmq::monitor_t {
 public:
  // `name` prefixes the log lines; `role` ("actor", "learner") names the keys folder to fix.
  ConnectionMonitor(zmq::socket_t& socket, const std::string& name, const std::string& role);
  // Reads the events that arrived; call it from the socket's own thread.
  void Poll();
  int64_t connects() const { return connects_; }
  bool connected() const { return connected_; }

 private:
  void on_event_connected(const zmq_event_t&, const char*) override;
  void on_event_disconnected(const zmq_event_t&, const char*) override;
  void on_event_handshake_failed_auth(const zmq_event_t& event, const char*) override;
  void on_event_handshake_failed_protocol(const zmq_event_t& event, const char*) override;
  void on_event_handshake_failed_no_detail(const zmq_event_t&, const char*) override;
  void Warn(const std::string& message);
  std::string name_, role_;
  std::chrono::steady_clock::time_point warned_{};
  int64_t connects_ = 0;
  bool connected_ = false;
};

}  // namespace ragdoll
