#include "common/endpoints.h"

#include <cerrno>
#include <cstdio>
#include <stdexcept>

#include "common/config_section.h"

namespace ragdoll {
Endpoints ReadEndpoints(const ConfigSection& s) {
  Endpoints e;
  e.host = s.Get<std::string>("host", e.host);
  e.bind = s.Get<std::string>("bind", IsLoopback(e.host) ? std::string("127.0.0.1") : e.bind);
  e.trajectory_port = s.GetPort("trajectory_port", e.trajectory_port);
  e.control_port = s.GetPort("control_port", e.control_port);
  e.snapshot_port = s.GetPort("snapshot_port", e.snapshot_port);
  e.learner_port = s.GetPort("learner_port", e.learner_port);
  e.learner_snapshot_port = s.GetPort("learner_snapshot_port", e.learner_snapshot_port);
  e.high_water_mark = s.Get<int>("high_water_mark", e.high_water_mark);
  if (e.high_water_mark < 1) s.Fail("high_water_mark", "must be at least 1");
  e.max_message_bytes = s.Get<int64_t>("max_message_bytes", e.max_message_bytes);
  if (e.max_message_bytes < 1024) s.Fail("max_message_bytes", "must be at least 1024");
  return e;
}

zmq::socket_t MakeSocket(zmq::context_t& context, zmq::socket_type type, const Endpoints& endpoints,
                         int receive_timeout_ms) {
  zmq::socket_t socket(context, type);
  socket.set(zmq::sockopt::linger, 0);
  socket.set(zmq::sockopt::sndhwm, endpoints.high_water_mark);
  socket.set(zmq::sockopt::rcvhwm, endpoints.high_water_mark);
  socket.set(zmq::sockopt::reconnect_ivl, 100);
  socket.set(zmq::sockopt::reconnect_ivl_max, 2000);
  socket.set(zmq::sockopt::rcvtimeo, receive_timeout_ms);
  socket.set(zmq::sockopt::sndtimeo, 1000);
  socket.set(zmq::sockopt::maxmsgsize, endpoints.max_message_bytes);
  if (endpoints.curve.enabled()) {
    socket.set(zmq::sockopt::curve_serverkey, endpoints.curve.server_key);
    socket.set(zmq::sockopt::curve_publickey, endpoints.curve.public_key);
    socket.set(zmq::sockopt::curve_secretkey, endpoints.curve.secret_key);
  }
  return socket;
}

zmq::socket_t MakeServerSocket(zmq::context_t& context, zmq::socket_type type,
                               const Endpoints& endpoints, const std::string& zap_domain) {
  Endpoints plain = endpoints;
  plain.curve = {};
  zmq::socket_t socket = MakeSocket(context, type, plain, 0);
  if (endpoints.curve.enabled()) {
    socket.set(zmq::sockopt::curve_server, 1);
    socket.set(zmq::sockopt::curve_secretkey, endpoints.curve.secret_key);
    socket.set(zmq::sockopt::zap_domain, zap_domain);
  }
  return socket;
}

void CheckTransportSecurity(const Endpoints& endpoints, bool insecure) {
  if (endpoints.curve.enabled() || insecure || IsLoopback(endpoints.bind)) return;
  throw std::runtime_error(
      "refusing to listen on " + endpoints.Bind(endpoints.trajectory_port) +
      " in plaintext: anyone who reaches these ports could push trajectories into training or "
      "read the weights. Make keys with `ragdoll keygen --keys keys` and give every role "
      "`--keys keys` (or security.keys in the config); see deploy/README.md, \"Keys\". On a "
      "network you trust, pass --insecure.");
}

bool Receive(zmq::socket_t& socket, zmq::message_t& message, zmq::recv_flags flags) {
  try {
    return socket.recv(message, flags).has_value();
  } catch (const zmq::error_t& e) {
    if (e.num() == EINTR) return false;
    throw;
  }
}

bool Send(zmq::socket_t& socket, zmq::const_buffer data, zmq::send_flags flags) {
  try {
    return socket.send(data, flags).has_value();
  } catch (const zmq::error_t& e) {
    if (e.num() == EINTR) return false;
    throw;
  }
}

ConnectionMonitor::ConnectionMonitor(zmq::socket_t& socket, const std::string& name,
                                     const std::string& role)
    : name_(name), role_(role) {
  init(socket, "inproc://monitor-" + name,
       ZMQ_EVENT_CONNECTED | ZMQ_EVENT_DISCONNECTED | ZMQ_EVENT_HANDSHAKE_FAILED_AUTH |
           ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL | ZMQ_EVENT_HANDSHAKE_FAILED_NO_DETAIL);
}

void ConnectionMonitor::Poll() {
  while (check_event(0)) {
  }
}

void ConnectionMonitor::on_event_connected(const zmq_event_t&, const char*) {
  ++connects_;
  connected_ = true;
}

void ConnectionMonitor::on_event_disconnected(const zmq_event_t&, const char*) {
  connected_ = false;
}

void ConnectionMonitor::on_event_handshake_failed_auth(const zmq_event_t& event, const char*) {
  Warn("the broker refused this " + role_ + "'s key (ZAP status " + std::to_string(event.value) +
       "): its public certificate must be in the broker's keys folder, under " + role_ + "s/");
}

void ConnectionMonitor::on_event_handshake_failed_protocol(const zmq_event_t& event, const char*) {
  Warn(event.value == ZMQ_PROTOCOL_ERROR_ZMTP_MECHANISM_MISMATCH
           ? "the broker and this " + role_ +
                 " disagree on security: one uses CURVE keys, the other plaintext (give every "
                 "role the same --keys folder)"
           : "the handshake with the broker failed (protocol error " + std::to_string(event.value) +
                 "): is KEYS/broker.key this broker's key?");
}

void ConnectionMonitor::on_event_handshake_failed_no_detail(const zmq_event_t&, const char*) {
  Warn("the handshake with the broker failed: the broker and this " + role_ +
       " disagree on security (CURVE keys or plaintext), or on the broker's key");
}

void ConnectionMonitor::Warn(const std::string& message) {
  const auto now = std::chrono::steady_clock::now();
  if (warned_ != std::chrono::steady_clock::time_point{} &&
      now - warned_ < std::chrono::seconds(30)) {
    return;
  }
  warned_ = now;
  std::fprintf(stderr, "%s: %s\n", name_.c_str(), message.c_str());
}

}  // namespace ragdoll
