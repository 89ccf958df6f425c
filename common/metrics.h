// Prometheus metrics: every process (learner, broker, each actor) serves its own registry over
// HTTP at /metrics. Names carry the `ragdoll_` prefix and base units; every family carries the
// run id as the `run` label, and the process's own constant labels (an actor's id).
#pragma once

#include <prometheus/counter.h>
#include <prometheus/gauge.h>
#include <prometheus/histogram.h>
#include <prometheus/registry.h>

#include <memory>
#include <string>
#include <vector>

struct MHD_Daemon;

namespace ragdoll {

class ConfigSection;

// The `metrics:` section of an experiment.
struct MetricsConfig {
  bool enabled = true;
  // The interface every role's HTTP endpoint listens on. Unset in the config: loopback when the
  // broker is on loopback (ResolveMetricsBind), else every interface.
  std::string bind;
  int learner_port = 9300;
  int broker_port = 9301;
  int actor_port = 9310;  // `ragdoll train` gives actor i the port actor_port + i
  // and learner replica i >= 1 the port learner_replica_port + i (replica 0: learner_port)
  int learner_replica_port = 9350;
};

MetricsConfig ReadMetricsConfig(const ConfigSection& section);
// The metrics bind a role uses: the configured one, else 127.0.0.1 when the broker is reached
// and listens on loopback (a training on one machine), else 0.0.0.0.
std::string ResolveMetricsBind(const MetricsConfig& metrics, const std::string& broker_host,
                               const std::string& broker_bind);

// One process's metrics: a registry and, when a port is given, the HTTP endpoint serving it in
// Prometheus's text format (prometheus-cpp's serializer) by libmicrohttpd, which serves many
// connections at once from one polling thread: a slow or silent client cannot hold it.
//
// Not prometheus-cpp's Exposer: its web server (civetweb) starts threads with a fixed 100 KB
// stack, smaller than the static TLS of the libraries libtorch brings into every role's process
// (OpenBLAS alone reserves 60 KB), so pthread_create fails with EINVAL and nothing is served.
class MetricsEndpoint {
 public:
  // Serves at bind:port; port <= 0 serves nothing while the metrics are still kept. A port that
  // cannot be bound is reported on stderr and training goes on without the endpoint: metrics
  // must never stop a run.
  MetricsEndpoint(const std::string& role, const std::string& bind, int port,
                  const std::string& run_id, const prometheus::Labels& labels = {});
  ~MetricsEndpoint();
  MetricsEndpoint(const MetricsEndpoint&) = delete;
  MetricsEndpoint& operator=(const MetricsEndpoint&) = delete;

  prometheus::Registry& registry() { return *registry_; }
  // The port listened on; 0 when not serving.
  int port() const { return daemon_ ? port_ : 0; }

  // Metric families with the constant labels; `labels` select one series.
  prometheus::Gauge& Gauge(const std::string& name, const std::string& help,
                           const prometheus::Labels& labels = {});
  prometheus::Counter& Counter(const std::string& name, const std::string& help,
                               const prometheus::Labels& labels = {});
  prometheus::Histogram& Histogram(const std::string& name, const std::string& help,
                                   const std::vector<double>& buckets,
                                   const prometheus::Labels& labels = {});

 private:
  std::shared_ptr<prometheus::Registry> registry_;
  prometheus::Labels labels_;  // on every family: run, and the constructor's labels
  int port_ = 0;
  MHD_Daemon* daemon_ = nullptr;  // serving; null when not
};

// Raises a Prometheus counter to a cumulative total kept elsewhere (never lowers it).
void AdvanceTo(prometheus::Counter& counter, double total);

}  // namespace ragdoll
