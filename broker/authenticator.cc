#include "broker/authenticator.h"

#include <zmq.h>

#include <cstdio>

#include "common/keys.h"

namespace ragdoll::broker {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// Reads one socket's monitor: handshakes that fail before ZAP decides.
class Authenticator::Watcher : public zmq::monitor_t {
 public:
  Watcher(Authenticator& owner, zmq::socket_t& socket, const std::string& name)
      : owner_(owner), name_(name) {
    init(socket, "inproc://ragdoll-broker-watch-" + name,
         ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL | ZMQ_EVENT_HANDSHAKE_FAILED_NO_DETAIL);
  }
  void Poll() {
    while (check_event(0)) {
    }
  }

 private:
  void on_event_handshake_failed_protocol(const zmq_event_t& event, const char* address) override {
    Reason reason = kProtocol;
    if (event.value == ZMQ_PROTOCOL_ERROR_ZMTP_MECHANISM_MISMATCH) reason = kNotCurve;
    if (event.value == ZMQ_PROTOCOL_ERROR_ZMTP_CRYPTOGRAPHIC) reason = kBadHandshake;
    char code[16];
    std::snprintf(code, sizeof(code), "0x%x", event.value);
    owner_.Refuse(reason, name_ + " socket, peer " + std::string(address ? address : "?") +
                              ", ZMTP error " + code);
  }
  void on_event_handshake_failed_no_detail(const zmq_event_t&, const char* address) override {
    owner_.Refuse(kProtocol, name_ + " socket, peer " + std::string(address ? address : "?"));
  }
  Authenticator& owner_;
  std::string name_;
};

const char* Authenticator::ReasonName(Reason reason) {
  switch (reason) {
    case kUnknownKey:
      return "unknown_key";
    case kWrongRole:
      return "wrong_role";
    case kNotCurve:
      return "not_curve";
    case kBadHandshake:
      return "bad_handshake";
    case kProtocol:
    case kReasons:
      break;
  }
  return "protocol";
}

Authenticator::Authenticator(zmq::context_t& context, const std::string& keys_dir,
                             MetricsEndpoint& metrics)
    : keys_dir_(keys_dir), zap_(context, zmq::socket_type::rep) {
  zap_.set(zmq::sockopt::linger, 0);
  zap_.bind("inproc://zeromq.zap.01");
  for (int role = 0; role < 2; ++role) {
    accepted_[role] = &metrics.Counter("ragdoll_broker_connections_accepted_total",
                                       "CURVE connections whose key the broker accepted",
                                       {{"role", role == 0 ? kActorDomain : kLearnerDomain}});
  }
  for (int r = 0; r < kReasons; ++r) {
    refused_[r] = &metrics.Counter(
        "ragdoll_broker_connections_refused_total",
        "Connections refused: unknown_key (not in the keys folder), wrong_role (a key of the "
        "other role), not_curve (a plaintext client), bad_handshake (a wrong broker key or "
        "tampering), protocol (anything else)",
        {{"reason", ReasonName(static_cast<Reason>(r))}});
  }
  ReloadIfChanged();
  std::fprintf(stderr, "broker: CURVE on; %zu actor and %zu learner keys accepted from %s\n",
               keys_.actors.size(), keys_.learners.size(), keys_dir_.c_str());
}

Authenticator::~Authenticator() = default;

void Authenticator::Watch(zmq::socket_t& socket, const std::string& name) {
  watchers_.push_back(std::make_unique<Watcher>(*this, socket, name));
}

void Authenticator::ReloadIfChanged() {
  const auto now = Clock::now();
  if (loaded_ && now - last_check_ < std::chrono::seconds(1)) return;
  last_check_ = now;
  const fs::path folders[2] = {fs::path(keys_dir_) / "actors", fs::path(keys_dir_) / "learners"};
  std::array<fs::file_time_type, 2> times{};
  for (int i = 0; i < 2; ++i) {
    std::error_code error;
    times[i] = fs::last_write_time(folders[i], error);
  }
  const bool first = !loaded_;
  if (!first && times == folder_times_) return;
  Keys keys;
  std::map<std::string, std::string> names;
  try {
    for (int i = 0; i < 2; ++i) {
      for (const Certificate& c : LoadPublicCertificates(folders[i].string())) {
        (i == 0 ? keys.actors : keys.learners).insert(c.public_key);
        names[c.public_key] = c.name;
      }
    }
  } catch (const std::exception& error) {
    if (first) throw;
    std::fprintf(stderr, "broker: keeping the previous keys: %s\n", error.what());
    folder_times_ = times;
    return;
  }
  if (!first) {
    std::fprintf(stderr, "broker: keys reloaded: %zu actor and %zu learner keys\n",
                 keys.actors.size(), keys.learners.size());
  }
  keys_ = std::move(keys);
  names_ = std::move(names);
  folder_times_ = times;
  loaded_ = true;
}

void Authenticator::Refuse(Reason reason, const std::string& detail) {
  refused_[reason]->Increment();
  const auto now = Clock::now();
  if (now - last_logged_[reason] > std::chrono::seconds(10)) {
    last_logged_[reason] = now;
    std::fprintf(stderr, "broker: refused a connection (%s): %s [%lld so far]\n",
                 ReasonName(reason), detail.c_str(),
                 static_cast<long long>(refused_[reason]->Value()));
  }
}

void Authenticator::HandleRequest() {
  std::vector<zmq::message_t> frames;
  for (;;) {
    zmq::message_t frame;
    if (!zap_.recv(frame, zmq::recv_flags::dontwait)) break;
    const bool more = frame.more();
    frames.push_back(std::move(frame));
    if (!more) break;
  }
  if (frames.empty()) return;
  // version, request id, domain, address, routing id, mechanism, credentials...
  std::string request_id = frames.size() > 1 ? frames[1].to_string() : "";
  std::string status = "400", text = "refused", user;
  if (frames.size() < 6 || frames[0].to_string() != "1.0") {
    Refuse(kProtocol, "malformed ZAP request");
  } else {
    const std::string domain = frames[2].to_string(), address = frames[3].to_string();
    const std::string mechanism = frames[5].to_string();
    if (mechanism != "CURVE" || frames.size() < 7 || frames[6].size() != 32) {
      Refuse(kNotCurve, mechanism + " from " + address);
    } else {
      char key[41];
      zmq_z85_encode(key, static_cast<const uint8_t*>(frames[6].data()), 32);
      ReloadIfChanged();
      const bool actor = keys_.actors.count(key) > 0, learner = keys_.learners.count(key) > 0;
      const bool fits = (domain == kActorDomain && actor) ||
                        (domain == kLearnerDomain && learner) ||
                        (domain == kControlDomain && (actor || learner));
      if (fits) {
        status = "200";
        text = "OK";
        const bool as_learner = domain == kLearnerDomain || (domain == kControlDomain && !actor);
        user = as_learner ? kLearnerDomain : kActorDomain;
        accepted_[as_learner ? 1 : 0]->Increment();
      } else if (actor || learner) {
        Refuse(kWrongRole, std::string(actor ? "actor" : "learner") + " key '" + names_[key] +
                               "' used on the " + domain + " socket, from " + address);
      } else {
        const std::string folders =
            domain == kControlDomain ? "actors/ or learners/" : domain + "s/";
        Refuse(kUnknownKey, "key " + std::string(key).substr(0, 8) + "... from " + address +
                                ": not in " + keys_dir_ + "/" + folders + " (" + domain +
                                " socket)");
      }
    }
  }
  const std::string reply[] = {"1.0", request_id, status, text, user, ""};
  for (size_t i = 0; i < 6; ++i) {
    zap_.send(zmq::buffer(reply[i]), i < 5 ? zmq::send_flags::sndmore : zmq::send_flags::none);
  }
}

void Authenticator::HandleRequests() {
  for (int i = 0; i < 64; ++i) {
    if ((zap_.get(zmq::sockopt::events) & ZMQ_POLLIN) == 0) break;
    HandleRequest();
  }
}

void Authenticator::ReadWatches() {
  for (auto& w : watchers_) w->Poll();
}

int64_t Authenticator::accepted() const {
  return static_cast<int64_t>(accepted_[0]->Value() + accepted_[1]->Value());
}

int64_t Authenticator::refused(Reason reason) const {
  return static_cast<int64_t>(refused_[reason]->Value());
}

std::string Authenticator::RoleOf(zmq::message_t& message) {
  const char* user = zmq_msg_gets(message.handle(), "User-Id");
  return user ? user : "";
}

}  // namespace ragdoll::broker
