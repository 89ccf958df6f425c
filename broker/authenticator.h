// The broker's gatekeeper under CURVE: a ZAP handler (ZeroMQ RFC 27, as czmq's zauth) that
// accepts a client only if its public key is in the keys folder of the role the socket serves
// (KEYS/actors/*.key or KEYS/learners/*.key), and a watch on the broker's sockets that counts
// handshakes failing before ZAP is asked (a plaintext client, a wrong broker key).
// Every refusal is counted by reason and logged at most every 10 s per reason.
#pragma once

#include <zmq.hpp>

#include <array>
#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "common/metrics.h"

namespace ragdoll::broker {

// The ZAP domain of each broker socket: the role allowed to connect to it.
inline constexpr const char* kActorDomain = "actor";
inline constexpr const char* kLearnerDomain = "learner";
inline constexpr const char* kControlDomain = "control";  // actors and learners

class Authenticator {
 public:
  enum Reason { kUnknownKey, kWrongRole, kNotCurve, kBadHandshake, kProtocol, kReasons };
  static const char* ReasonName(Reason reason);

  // Binds the context's ZAP endpoint (before any CURVE server socket binds, or libzmq would let
  // clients in unchecked) and reads the keys; throws naming a bad certificate.
  Authenticator(zmq::context_t& context, const std::string& keys_dir, MetricsEndpoint& metrics);
  ~Authenticator();

  // Counts the handshakes of `socket` that fail before authentication.
  void Watch(zmq::socket_t& socket, const std::string& name);

  // The ZAP socket, for the broker's poll loop.
  zmq::socket_t& socket() { return zap_; }
  // Answers the waiting ZAP requests (when the socket polls readable).
  void HandleRequests();
  // Reads the socket watches' events (often enough: every half second).
  void ReadWatches();

  int64_t accepted() const;
  int64_t refused(Reason reason) const;

  // The role of an authenticated sender ("actor" or "learner"), from the User-Id the handler
  // gave its connection; empty when the message came in plaintext.
  static std::string RoleOf(zmq::message_t& message);

 private:
  struct Keys {
    std::set<std::string> actors, learners;  // Z85 public keys
  };
  void ReloadIfChanged();
  void Refuse(Reason reason, const std::string& detail);
  void HandleRequest();

  std::string keys_dir_;
  zmq::socket_t zap_;
  Keys keys_;
  std::map<std::string, std::string> names_;  // key -> certificate name, for the log
  std::array<std::filesystem::file_time_type, 2> folder_times_{};
  bool loaded_ = false;  // the folders were read once (a bad key then stops start-up)
  std::chrono::steady_clock::time_point last_check_{};
  std::array<std::chrono::steady_clock::time_point, kReasons> last_logged_{};
  prometheus::Counter* accepted_[2] = {nullptr, nullptr};  // actor, learner
  std::array<prometheus::Counter*, kReasons> refused_{};
  class Watcher;
  std::vector<std::unique_ptr<Watcher>> watchers_;
};

}  // namespace ragdoll::broker
