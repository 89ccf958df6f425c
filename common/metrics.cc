#include "common/metrics.h"

#include <netdb.h>
#include <poll.h>
#include <prometheus/text_serializer.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <sstream>

#include "common/config_section.h"

namespace ragdoll {
MetricsConfig ReadMetricsConfig(const ConfigSection& s) {
  MetricsConfig m;
  m.enabled = s.Get<bool>("enabled", m.enabled);
  m.bind = s.Get<std::string>("bind", m.bind);
  if (m.bind.empty()) s.Fail("bind", "must name an interface address, e.g. 0.0.0.0");
  m.learner_port = s.GetPort("learner_port", m.learner_port);
  m.broker_port = s.GetPort("broker_port", m.broker_port);
  m.actor_port = s.GetPort("actor_port", m.actor_port);
  m.learner_replica_port = s.GetPort("learner_replica_port", m.learner_replica_port);
  s.Finish();
  return m;
}

MetricsEndpoint::MetricsEndpoint(const std::string& role, const std::string& bind, int port,
                                 const std::string& run_id, const prometheus::Labels& labels)
    : registry_(std::make_shared<prometheus::Registry>()), labels_(labels), port_(port) {
  labels_["run"] = run_id;
  if (port <= 0) return;
  const std::string address = bind + ":" + std::to_string(port);
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* found = nullptr;
  const std::string service = std::to_string(port);
  std::string error;
  if (int r = getaddrinfo(bind.empty() ? nullptr : bind.c_str(), service.c_str(), &hints, &found)) {
    error = gai_strerror(r);
  } else {
    for (addrinfo* a = found; a && listening_ < 0; a = a->ai_next) {
      int fd = socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC, a->ai_protocol);
      if (fd < 0) continue;
      int yes = 1;
      setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
      if (::bind(fd, a->ai_addr, a->ai_addrlen) == 0 && listen(fd, 16) == 0) {
        listening_ = fd;
      } else {
        error = std::strerror(errno);
        close(fd);
      }
    }
    freeaddrinfo(found);
  }
  if (listening_ < 0) {
    std::fprintf(stderr, "%s: warning: cannot serve metrics on %s (%s); continuing without\n",
                 role.c_str(), address.c_str(), error.c_str());
    return;
  }
  std::fprintf(stderr, "%s: metrics at http://%s/metrics\n", role.c_str(), address.c_str());
  server_ = std::thread([this] { Serve(); });
}

MetricsEndpoint::~MetricsEndpoint() {
  stop_.store(true);
  if (server_.joinable()) server_.join();
  if (listening_ >= 0) close(listening_);
}

void MetricsEndpoint::Serve() {
  while (!stop_.load()) {
    pollfd p{listening_, POLLIN, 0};
    if (poll(&p, 1, 200) <= 0) continue;  // timeout (check the stop flag) or EINTR
    int connection = accept4(listening_, nullptr, nullptr, SOCK_CLOEXEC);
    if (connection < 0) continue;
    Answer(connection);
    close(connection);
  }
}

// One request per connection (HTTP/1.0 semantics, which Prometheus and curl handle): GET
// /metrics answers the registry in the text exposition format, anything else 404 or 405.
void MetricsEndpoint::Answer(int connection) {
  timeval timeout{2, 0};  // a client that sends nothing must not hold the endpoint
  setsockopt(connection, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));
  setsockopt(connection, SOL_SOCKET, SO_SNDTIMEO, &timeout, sizeof(timeout));
  std::string request;
  char buffer[2048];
  while (request.find("\r\n\r\n") == std::string::npos && request.size() < 16384) {
    ssize_t n = recv(connection, buffer, sizeof(buffer), 0);
    if (n <= 0) break;
    request.append(buffer, static_cast<size_t>(n));
  }
  std::istringstream line(request.substr(0, request.find("\r\n")));
  std::string method, target;
  line >> method >> target;
  std::string status = "200 OK", type = "text/plain; version=0.0.4; charset=utf-8", body;
  const std::string path = target.substr(0, target.find('?'));
  if (method != "GET" && method != "HEAD") {
    status = "405 Method Not Allowed";
    body = "only GET\n";
  } else if (path != "/metrics" && path != "/") {
    status = "404 Not Found";
    body = "metrics are at /metrics\n";
  } else {
    body = prometheus::TextSerializer().Serialize(registry_->Collect());
  }
  if (method == "HEAD") body.clear();
  std::string response = "HTTP/1.1 " + status + "\r\nContent-Type: " + type +
                         "\r\nContent-Length: " + std::to_string(body.size()) +
                         "\r\nConnection: close\r\n\r\n" + body;
  for (size_t sent = 0; sent < response.size();) {
    ssize_t n = send(connection, response.data() + sent, response.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) break;
    sent += static_cast<size_t>(n);
  }
}

prometheus::Gauge& MetricsEndpoint::Gauge(const std::string& name, const std::string& help,
                                          const prometheus::Labels& labels) {
  return prometheus::BuildGauge()
      .Name(name)
      .Help(help)
      .Labels(labels_)
      .Register(*registry_)
      .Add(labels);
}

prometheus::Counter& MetricsEndpoint::Counter(const std::string& name, const std::string& help,
                                              const prometheus::Labels& labels) {
  return prometheus::BuildCounter()
      .Name(name)
      .Help(help)
      .Labels(labels_)
      .Register(*registry_)
      .Add(labels);
}

prometheus::Histogram& MetricsEndpoint::Histogram(const std::string& name, const std::string& help,
                                                  const std::vector<double>& buckets,
                                                  const prometheus::Labels& labels) {
  return prometheus::BuildHistogram()
      .Name(name)
      .Help(help)
      .Labels(labels_)
      .Register(*registry_)
      .Add(labels, buckets);
}

void AdvanceTo(prometheus::Counter& counter, double total) {
  double delta = total - counter.Value();
  if (delta > 0) counter.Increment(delta);
}

}  // namespace ragdoll
