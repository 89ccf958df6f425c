#include "common/metrics.h"

#include <microhttpd.h>
#include <netdb.h>
#include <prometheus/text_serializer.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "common/config_section.h"
#include "common/keys.h"

namespace ragdoll {
MetricsConfig ReadMetricsConfig(const ConfigSection& s) {
  MetricsConfig m;
  m.enabled = s.Get<bool>("enabled", m.enabled);
  m.bind = s.Get<std::string>("bind", m.bind);
  if (s.Has("bind") && m.bind.empty()) {
    s.Fail("bind", "must name an interface address, e.g. 127.0.0.1 or 0.0.0.0");
  }
  m.learner_port = s.GetPort("learner_port", m.learner_port);
  m.broker_port = s.GetPort("broker_port", m.broker_port);
  m.actor_port = s.GetPort("actor_port", m.actor_port);
  m.learner_replica_port = s.GetPort("learner_replica_port", m.learner_replica_port);
  s.Finish();
  return m;
}

std::string ResolveMetricsBind(const MetricsConfig& metrics, const std::string& broker_host,
                               const std::string& broker_bind) {
  if (!metrics.bind.empty()) return metrics.bind;
  return IsLoopback(broker_host) && IsLoopback(broker_bind) ? "127.0.0.1" : "0.0.0.0";
}

namespace {
// Many scrapers and an attacker's idle or trickling connections are served side by side by one
// polling thread; a connection idle this long is closed, and past the limit new ones are refused
// (each holds a descriptor and libmicrohttpd's per-connection memory, 32 KB by default).
constexpr unsigned kIdleTimeoutSeconds = 5;
constexpr unsigned kConnectionLimit = 512;

// The listening socket, bound by us so that the address may be any name or IPv6; -1 and the
// reason when it cannot be bound.
int Listen(const std::string& bind, int port, std::string& error) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* found = nullptr;
  const std::string service = std::to_string(port);
  if (int r = getaddrinfo(bind.empty() ? nullptr : bind.c_str(), service.c_str(), &hints, &found)) {
    error = gai_strerror(r);
    return -1;
  }
  int listening = -1;
  for (addrinfo* a = found; a && listening < 0; a = a->ai_next) {
    int fd = socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC | SOCK_NONBLOCK, a->ai_protocol);
    if (fd < 0) continue;
    int yes = 1;
    setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
    if (::bind(fd, a->ai_addr, a->ai_addrlen) == 0 && listen(fd, 128) == 0) {
      listening = fd;
    } else {
      error = std::strerror(errno);
      close(fd);
    }
  }
  freeaddrinfo(found);
  return listening;
}

// libmicrohttpd answers HEAD itself: the headers of the same response, without its body.
MHD_Result Queue(MHD_Connection* connection, unsigned status, const std::string& body) {
  MHD_Response* response = MHD_create_response_from_buffer(
      body.size(), const_cast<char*>(body.data()), MHD_RESPMEM_MUST_COPY);
  if (!response) return MHD_NO;
  MHD_add_response_header(response, MHD_HTTP_HEADER_CONTENT_TYPE,
                          "text/plain; version=0.0.4; charset=utf-8");
  const MHD_Result queued = MHD_queue_response(connection, status, response);
  MHD_destroy_response(response);
  return queued;
}
// GET (or HEAD) /metrics answers the registry in the text exposition format; other paths 404,
// other methods 405. A request body is never read: the connection is answered at its headers.
MHD_Result Answer(void* registry, MHD_Connection* connection, const char* url, const char* method,
                  const char* /*version*/, const char* /*upload_data*/,
                  size_t* /*upload_data_size*/, void** /*request*/) {
  const std::string m = method;
  const std::string path = url;
  if (m != MHD_HTTP_METHOD_GET && m != MHD_HTTP_METHOD_HEAD) {
    return Queue(connection, MHD_HTTP_METHOD_NOT_ALLOWED, "only GET\n");
  }
  if (path != "/metrics" && path != "/") {
    return Queue(connection, MHD_HTTP_NOT_FOUND, "metrics are at /metrics\n");
  }
  return Queue(connection, MHD_HTTP_OK,
               prometheus::TextSerializer().Serialize(
                   static_cast<prometheus::Registry*>(registry)->Collect()));
}

}  // namespace

MetricsEndpoint::MetricsEndpoint(const std::string& role, const std::string& bind, int port,
                                 const std::string& run_id, const prometheus::Labels& labels)
    : registry_(std::make_shared<prometheus::Registry>()), labels_(labels), port_(port) {
  labels_["run"] = run_id;
  if (port <= 0) return;
  const std::string address = bind + ":" + std::to_string(port);
  std::string error;
  const int listening = Listen(bind, port, error);
  if (listening >= 0) {
    // libmicrohttpd's own polling thread (epoll or poll, never select's descriptor limit); it
    // takes the socket and closes it when stopped.
    daemon_ = MHD_start_daemon(MHD_USE_AUTO_INTERNAL_THREAD, 0, nullptr, nullptr, &Answer,
                               registry_.get(), MHD_OPTION_LISTEN_SOCKET, listening,
                               MHD_OPTION_CONNECTION_TIMEOUT, kIdleTimeoutSeconds,
                               MHD_OPTION_CONNECTION_LIMIT, kConnectionLimit, MHD_OPTION_END);
    if (!daemon_) {
      error = "libmicrohttpd did not start";
      close(listening);
    }
  }
  if (!daemon_) {
    std::fprintf(stderr, "%s: warning: cannot serve metrics on %s (%s); continuing without\n",
                 role.c_str(), address.c_str(), error.c_str());
    return;
  }
  std::fprintf(stderr, "%s: metrics at http://%s/metrics\n", role.c_str(), address.c_str());
}

MetricsEndpoint::~MetricsEndpoint() {
  if (daemon_) MHD_stop_daemon(daemon_);
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
