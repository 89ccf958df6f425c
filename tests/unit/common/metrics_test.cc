#include "common/metrics.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/config_section.h"

namespace ragdoll {
namespace {

// A plain HTTP/1.0 GET on loopback: the status line, headers and body as received.
std::string HttpGet(int port, const std::string& path) {
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) != 0) {
    close(fd);
    return "";
  }
  std::string request = "GET " + path + " HTTP/1.0\r\nHost: localhost\r\n\r\n";
  if (write(fd, request.data(), request.size()) != static_cast<ssize_t>(request.size())) {
    close(fd);
    return "";
  }
  std::string response;
  char buffer[4096];
  for (ssize_t n; (n = read(fd, buffer, sizeof(buffer))) > 0;) response.append(buffer, n);
  close(fd);
  return response;
}

// An endpoint on a free port (random ones until one binds).
std::unique_ptr<MetricsEndpoint> Serve(const std::string& run) {
  std::mt19937 rng(std::random_device{}());
  for (int attempt = 0; attempt < 20; ++attempt) {
    auto m = std::make_unique<MetricsEndpoint>("test", "127.0.0.1",
                                               30000 + static_cast<int>(rng() % 30000), run);
    if (m->port() > 0) return m;
  }
  throw std::runtime_error("no free port");
}

TEST(Metrics, ServesTheRegistryWithTheRunLabel) {
  auto served = Serve("run-7");
  MetricsEndpoint& m = *served;
  m.Counter("ragdoll_test_things_total", "things").Increment(3);
  m.Gauge("ragdoll_test_level", "level", {{"actor", "a1"}}).Set(0.25);
  m.Histogram("ragdoll_test_duration_seconds", "duration", {1, 2}).Observe(1.5);
  std::string page = HttpGet(m.port(), "/metrics");
  EXPECT_NE(page.find("200 OK"), std::string::npos) << page;
  EXPECT_NE(page.find("ragdoll_test_things_total{run=\"run-7\"} 3"), std::string::npos) << page;
  EXPECT_NE(page.find("ragdoll_test_level{run=\"run-7\",actor=\"a1\"} 0.25"), std::string::npos)
      << page;
  EXPECT_NE(page.find("ragdoll_test_duration_seconds_bucket{run=\"run-7\",le=\"2\"} 1"),
            std::string::npos)
      << page;
  // Anything but GET /metrics is refused with a status, not served or crashed on.
  EXPECT_NE(HttpGet(m.port(), "/other").find("404"), std::string::npos);
  EXPECT_NE(HttpGet(m.port(), "/metrics?x=1").find("ragdoll_test_things_total"), std::string::npos);
}

// A client that connects and sends nothing, and one that sends half a request, hold their own
// connections only: a scrape beside them is answered at once (the old single-connection server
// answered only after their 2 s timeouts).
TEST(Metrics, SilentAndHalfSentClientsDoNotHoldTheEndpoint) {
  auto served = Serve("r");
  served->Counter("ragdoll_test_total", "t").Increment();
  std::vector<int> held;
  for (int i = 0; i < 20; ++i) {
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<uint16_t>(served->port()));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)), 0);
    if (i % 2) {
      ASSERT_EQ(write(fd, "GET /met", 8), 8);
    }
    held.push_back(fd);
  }
  const auto start = std::chrono::steady_clock::now();
  const std::string page = HttpGet(served->port(), "/metrics");
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_NE(page.find("ragdoll_test_total{run=\"r\"} 1"), std::string::npos) << page;
  EXPECT_LT(seconds, 1.0);  // not a benchmark: the old server took at least 2 s per held client
  for (int fd : held) close(fd);
}

TEST(Metrics, AdvanceToOnlyRaisesACounter) {
  MetricsEndpoint m("test", "127.0.0.1", -1, "r");
  prometheus::Counter& c = m.Counter("ragdoll_test_total", "t");
  AdvanceTo(c, 5);
  AdvanceTo(c, 3);  // a total kept elsewhere went back (a restart): the counter never does
  EXPECT_EQ(c.Value(), 5);
  AdvanceTo(c, 7.5);
  EXPECT_EQ(c.Value(), 7.5);
}

TEST(Metrics, APortInUseIsNotFatal) {
  auto first = Serve("r");
  MetricsEndpoint second("second", "127.0.0.1", first->port(), "r");
  EXPECT_EQ(second.port(), 0);
  second.Counter("ragdoll_test_total", "t").Increment();  // still usable, just not served
}

TEST(Metrics, NoEndpointWithoutAPort) {
  MetricsEndpoint none("test", "127.0.0.1", -1, "r");
  EXPECT_EQ(none.port(), 0);
  MetricsEndpoint zero("test", "127.0.0.1", 0, "r");
  EXPECT_EQ(zero.port(), 0);
}

TEST(MetricsConfig, ReadsAndChecksTheSection) {
  auto root = ConfigSection::FromString(
      "metrics:\n  bind: 127.0.0.1\n  learner_port: 9400\n  actor_port: 9500\n", "m.yaml");
  MetricsConfig c = ReadMetricsConfig(root.Section("metrics"));
  EXPECT_EQ(c.bind, "127.0.0.1");
  EXPECT_EQ(c.learner_port, 9400);
  EXPECT_EQ(c.broker_port, 9301);
  EXPECT_EQ(c.actor_port, 9500);
  EXPECT_TRUE(c.enabled);
  auto bad = ConfigSection::FromString("metrics:\n  broker_port: 70000\n", "m.yaml");
  EXPECT_THROW(
      {
        try {
          ReadMetricsConfig(bad.Section("metrics"));
        } catch (const ConfigError& e) {
          EXPECT_NE(std::string(e.what()).find("metrics.broker_port"), std::string::npos)
              << e.what();
          throw;
        }
      },
      ConfigError);
  auto typo = ConfigSection::FromString("metrics:\n  learner_prot: 1\n", "m.yaml");
  EXPECT_THROW(ReadMetricsConfig(typo.Section("metrics")), ConfigError);
  auto empty = ConfigSection::FromString("metrics:\n  bind: ''\n", "m.yaml");
  EXPECT_THROW(ReadMetricsConfig(empty.Section("metrics")), ConfigError);
}

// Unset, the bind follows the broker: loopback for a training on one machine, every interface
// when the broker is reached or listens beyond it; a configured bind always wins.
TEST(MetricsConfig, TheBindFollowsTheBrokerUnlessSet) {
  MetricsConfig unset;
  EXPECT_EQ(ResolveMetricsBind(unset, "127.0.0.1", "127.0.0.1"), "127.0.0.1");
  EXPECT_EQ(ResolveMetricsBind(unset, "localhost", "127.0.0.1"), "127.0.0.1");
  EXPECT_EQ(ResolveMetricsBind(unset, "broker", "*"), "0.0.0.0");
  EXPECT_EQ(ResolveMetricsBind(unset, "127.0.0.1", "*"), "0.0.0.0");
  EXPECT_EQ(ResolveMetricsBind(unset, "10.0.0.5", "127.0.0.1"), "0.0.0.0");
  MetricsConfig set;
  set.bind = "10.1.2.3";
  EXPECT_EQ(ResolveMetricsBind(set, "127.0.0.1", "127.0.0.1"), "10.1.2.3");
}

}  // namespace
}  // namespace ragdoll
