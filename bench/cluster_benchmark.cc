// How far one broker and N learner replicas carry a cluster, measured on loopback with the real
// `ragdoll broker` and `ragdoll learner` processes fed by synthetic actors: threads that replay
// trajectory segments recorded from the real environment (valid messages, no physics), stamped
// with the newest policy version they have heard of.
//   ragdoll-bench-cluster CONFIG [--seconds S] [--threads 1,2] [--replicas 1,2] [--subscribers 100]
//                         [--pin [--harness-cores LIST]] [--repeats N]
// --pin gives learner replica i (of T threads) cores i*T..i*T+T-1; --harness-cores keeps the
// broker, the synthetic actors and this process on other cores, so that on a machine with cores
// to spare nothing of the benchmark's runs on the learners' (without it they float over all).
// It prints, and with --json writes:
//   broker:    forwarding ceiling with a sink for a learner (segments/s, samples/s, MB/s, the
//              broker's CPU share, and samples/s per broker core);
//   learner:   per (threads, replicas), the samples/s trained when offered more than it takes
//              and the stale-drop fraction then; and its absorption: the highest offered rate
//              that it keeps pace with (trains 95 % of it) with under 1 % of segments going
//              stale (searched up and down from 90 % of the flooded rate, or for replicas from
//              77 % of linear scaling of one replica in the same round when higher), with the CPU
//              the learners, the broker and the synthetic actors used there, the median update's
//              seconds and the learners' idle fraction; with --repeats, medians, and each replica
//              group's median ratio to one replica measured in the same round;
//   snapshots: time for one snapshot to reach every one of --subscribers actors.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sched.h>
#include <sys/socket.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>
#include <vector>

#include "actor/rollout.h"
#include "common/allocator.h"
#include "common/blas.h"
#include "common/endpoints.h"
#include "common/median.h"
#include "common/process.h"
#include "common/wire.h"
#include "learner/learner.h"
#include "learner/metrics_csv.h"
#include "run/experiment.h"

namespace {

namespace fs = std::filesystem;
using namespace ragdoll;
using Clock = std::chrono::steady_clock;
const char* kRun = "bench-cluster";

double Since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// Pins the calling thread, and the threads and processes it starts afterwards, to `cores`.
void PinTo(const std::vector<int>& cores) {
  cpu_set_t set;
  CPU_ZERO(&set);
  for (int core : cores) CPU_SET(core, &set);
  sched_setaffinity(0, sizeof(set), &set);
}

// A child process running `ragdoll ROLE ...`; stopped with SIGTERM (then SIGKILL) on destruction.
class Process {
 public:
  // `cores`, when given, pins the process to them; otherwise it runs where this thread may.
  Process(const std::string& ragdoll, std::vector<std::string> args, std::vector<int> cores = {})
      : child_(WithProgram(ragdoll, std::move(args)), RoleOptions(ragdoll, std::move(cores))) {}
  // CPU seconds (user + system) used so far, from /proc.
  double CpuSeconds() const {
    std::ifstream in("/proc/" + std::to_string(child_.pid()) + "/stat");
    std::string line;
    std::getline(in, line);
    std::istringstream fields(line.substr(line.rfind(')') + 2));
    std::string f;
    double ticks = 0;
    for (int i = 3; i <= 15 && fields >> f; ++i) {
      if (i == 14 || i == 15) ticks += std::stod(f);
    }
    return ticks / static_cast<double>(sysconf(_SC_CLK_TCK));
  }

 private:
  static std::vector<std::string> WithProgram(const std::string& ragdoll,
                                              std::vector<std::string> args) {
    args.insert(args.begin(), ragdoll);
    return args;
  }
  static ChildProcess::Options RoleOptions(const std::string& ragdoll, std::vector<int> cores) {
    ChildProcess::Options options;
    options.program = ragdoll;
    // Keep the bench's own output readable: the roles' logs go to a file.
    options.output = ChildProcess::Output::kLog;
    options.log = "/tmp/ragdoll-bench-cluster.log";
    options.append = true;
    options.cores = std::move(cores);
    options.grace_seconds = 6;
    return options;
  }

  ChildProcess child_;
};

// One series' value from a role's /metrics (summed over label sets); -1 when unreachable.
double Scrape(int port, const std::string& name) {
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address = {};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port));
  inet_pton(AF_INET, "127.0.0.1", &address.sin_addr);
  if (connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) != 0) {
    close(fd);
    return -1;
  }
  const std::string request = "GET /metrics HTTP/1.0\r\nHost: localhost\r\n\r\n";
  if (write(fd, request.data(), request.size()) < 0) {
    close(fd);
    return -1;
  }
  std::string body;
  char buffer[65536];
  for (ssize_t n; (n = read(fd, buffer, sizeof(buffer))) > 0;) body.append(buffer, n);
  close(fd);
  std::istringstream lines(body);
  double sum = 0;
  bool found = false;
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind(name, 0) != 0) continue;
    const char next = line.size() > name.size() ? line[name.size()] : '\0';
    if (next != ' ' && next != '{') continue;
    sum += std::stod(line.substr(line.rfind(' ') + 1));
    found = true;
  }
  return found ? sum : -1;
}

// CPU seconds (user + system) of this process: the synthetic actors' threads.
double OwnCpuSeconds() {
  timespec t = {};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

struct Recording {
  std::vector<v1::TrajectorySegment> segments;
  int time_horizon = 0;
  double bytes_per_sample = 0;
  std::string snapshot;  // a real snapshot message of this network
};

// Segments from the real environment with a fresh policy: what actors send, byte for byte.
Recording Record(const run::Experiment& e, int count) {
  Recording r;
  r.time_horizon = e.trainer.time_horizon;
  actor::RolloutWorker worker(e.environment, 8, r.time_horizon, 1, "bench-actor");
  learner::Learner learner(e.trainer, worker.spec().observation_size, worker.spec().action_size);
  const v1::PolicySnapshot snapshot = learner.Snapshot();
  worker.SetPolicy(snapshot);
  r.snapshot = wire::Pack(v1::KIND_SNAPSHOT, kRun, "learner", snapshot, 0);
  while (static_cast<int>(r.segments.size()) < count) {
    for (auto& s : worker.Collect()) r.segments.push_back(std::move(s));
  }
  r.segments.resize(static_cast<size_t>(count));
  double bytes = 0;
  for (const auto& s : r.segments) bytes += wire::Pack(v1::KIND_TRAJECTORY, kRun, "a", s).size();
  r.bytes_per_sample = bytes / (static_cast<double>(count) * r.time_horizon);
  return r;
}

// Synthetic actors: threads that push the recorded segments round and round, stamped with the
// newest snapshot version the broker has published, at `rate` samples/s in total (0: as fast as
// the broker takes them).
class Replay {
 public:
  Replay(zmq::context_t& context, const Endpoints& endpoints, const Recording& recording,
         int threads, double rate)
      : recording_(recording) {
    Stamp(0);
    for (int i = 0; i < threads; ++i) {
      workers_.emplace_back([this, &context, endpoints, threads, rate, i] {
        zmq::socket_t push = MakeSocket(context, zmq::socket_type::push, endpoints);
        zmq::socket_t snapshots = MakeSocket(context, zmq::socket_type::sub, endpoints, 0);
        snapshots.set(zmq::sockopt::conflate, 1);
        snapshots.set(zmq::sockopt::subscribe, "");
        push.connect(endpoints.Connect(endpoints.trajectory_port));
        snapshots.connect(endpoints.Connect(endpoints.snapshot_port));
        const double per_thread = rate / threads;
        const double segment_samples = recording_.time_horizon;
        const auto start = Clock::now();
        int64_t sent = 0;
        size_t next = static_cast<size_t>(i);
        while (!stop_.load()) {
          zmq::message_t m;
          if (snapshots.recv(m, zmq::recv_flags::dontwait)) {
            v1::Header h;
            size_t offset = 0;
            if (wire::ReadHeader(m.data(), m.size(), endpoints.max_message_bytes, &h, &offset)
                    .ok() &&
                h.kind() == v1::KIND_SNAPSHOT) {
              Stamp(h.policy_version());
            }
          }
          if (per_thread > 0) {
            // Asleep until this thread's next segment is due, so that the replay takes little
            // of the learners' CPU (docs/learner-scaling.md has the figure).
            const double due = sent * segment_samples / per_thread;
            if (due > Since(start)) {
              std::this_thread::sleep_until(start + std::chrono::duration_cast<Clock::duration>(
                                                        std::chrono::duration<double>(due)));
              continue;
            }
          }
          std::shared_ptr<const std::vector<std::string>> frames;
          {
            std::lock_guard<std::mutex> lock(mutex_);
            frames = frames_;
          }
          const std::string& frame = (*frames)[next % frames->size()];
          if (Send(push, zmq::buffer(frame), zmq::send_flags::dontwait)) {
            ++sent;
            next += static_cast<size_t>(threads);
            offered_.fetch_add(1);
          } else {
            // Flooding, the learners' queues are full (the broker reads only what they can
            // take): wait until there is room or a snapshot comes, since retrying spins on the
            // learners' cores (docs/learner-scaling.md).
            zmq::pollitem_t items[] = {{push.handle(), 0, ZMQ_POLLOUT, 0},
                                       {snapshots.handle(), 0, ZMQ_POLLIN, 0}};
            zmq::poll(items, 2, std::chrono::milliseconds(50));
          }
        }
      });
    }
  }
  ~Replay() {
    stop_.store(true);
    for (auto& w : workers_) w.join();
  }
  int64_t offered() const { return offered_.load(); }

 private:
  // One thread stamps each new version; the others send the previous frames meanwhile.
  void Stamp(int64_t version) {
    int64_t claimed = claimed_.load();
    do {
      if (version <= claimed) return;
    } while (!claimed_.compare_exchange_weak(claimed, version));
    auto frames = std::make_shared<std::vector<std::string>>();
    for (auto s : recording_.segments) {
      s.set_policy_version(version);
      frames->push_back(wire::Pack(v1::KIND_TRAJECTORY, kRun, "bench-actor", s, version));
    }
    std::lock_guard<std::mutex> lock(mutex_);
    if (version < version_.load()) return;
    version_.store(version);
    frames_ = frames;
  }

  const Recording& recording_;
  std::mutex mutex_;
  std::shared_ptr<const std::vector<std::string>> frames_;
  std::atomic<int64_t> version_{-1}, claimed_{-1};
  std::atomic<bool> stop_{false};
  std::atomic<int64_t> offered_{0};
  std::vector<std::thread> workers_;
};

struct Ports {
  int base;
  Endpoints endpoints;  // plaintext, or CURVE with an actor's keys
  Endpoints learner;    // the same with the learner's keys
  std::string keys;     // the CURVE keys folder; empty: plaintext
  int learner_metrics(int index) const { return index == 0 ? base + 10 : base + 50 + index; }
  int broker_metrics() const { return base + 11; }
  // The options that give a ragdoll process the keys.
  std::vector<std::string> KeyArgs() const {
    return keys.empty() ? std::vector<std::string>{} : std::vector<std::string>{"--keys", keys};
  }
};

// A ragdoll role's command line: ROLE CONFIG --run-id --port-base, the keys, then `extra`.
std::vector<std::string> RoleArgs(const std::string& role, const std::string& config,
                                  const Ports& ports, std::vector<std::string> extra = {}) {
  std::vector<std::string> a = {role, config,        "--run-id",
                                kRun, "--port-base", std::to_string(ports.base)};
  for (auto& k : ports.KeyArgs()) a.push_back(k);
  for (auto& x : extra) a.push_back(x);
  return a;
}

Ports MakePorts(int base, const Endpoints& from, const std::string& keys) {
  Ports p{base, from, from, keys};
  p.endpoints.host = "127.0.0.1";
  p.endpoints.trajectory_port = base;
  p.endpoints.control_port = base + 1;
  p.endpoints.snapshot_port = base + 2;
  p.endpoints.learner_port = base + 3;
  p.endpoints.learner_snapshot_port = base + 4;
  p.endpoints.curve = LoadCurve(keys, "actor");
  p.learner = p.endpoints;
  p.learner.curve = LoadCurve(keys, "learner");
  return p;
}

bool WaitFor(double seconds, const std::function<bool()>& done) {
  const auto start = Clock::now();
  while (Since(start) < seconds) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return done();
}

// The broker with a sink in the learner's place: its forwarding ceiling.
nlohmann::json BenchBroker(const std::string& ragdoll, const std::string& config,
                           const Recording& rec, const Ports& ports, double seconds, int senders) {
  Process broker(ragdoll, RoleArgs("broker", config, ports));
  zmq::context_t context(2);
  std::atomic<bool> stop{false};
  std::atomic<int64_t> received{0}, bytes{0};
  std::thread sink([&] {
    zmq::socket_t pull = MakeSocket(context, zmq::socket_type::pull, ports.learner);
    pull.connect(ports.endpoints.Connect(ports.endpoints.learner_port));
    while (!stop.load()) {
      zmq::message_t m;
      if (Receive(pull, m)) {
        received.fetch_add(1);
        bytes.fetch_add(static_cast<int64_t>(m.size()));
      }
    }
  });
  nlohmann::json out;
  {
    Replay replay(context, ports.endpoints, rec, senders, 0);
    WaitFor(10, [&] { return received.load() > 100; });
    std::this_thread::sleep_for(std::chrono::seconds(1));
    const int64_t r0 = received.load(), b0 = bytes.load();
    const double cpu0 = broker.CpuSeconds();
    const auto t0 = Clock::now();
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    const double wall = Since(t0);
    const double segments = (received.load() - r0) / wall;
    const double cpu = (broker.CpuSeconds() - cpu0) / wall;
    out = {{"segments_per_s", segments},
           {"samples_per_s", segments * rec.time_horizon},
           {"MB_per_s", (bytes.load() - b0) / wall / 1e6},
           {"broker_cpu_cores", cpu},
           {"samples_per_s_per_broker_core", segments * rec.time_horizon / std::max(cpu, 1e-9)}};
  }
  stop.store(true);
  sink.join();
  return out;
}

// The experiment with this thread count and nothing else changed (no checkpoints meanwhile),
// written into `dir`; its path.
fs::path WriteBenchConfig(const run::Experiment& e, int threads, const fs::path& dir) {
  YAML::Node node = YAML::Clone(e.tree);
  node["trainer"]["threads"] = threads;
  node["trainer"]["max_steps"] = 1e12;
  node["trainer"]["checkpoint_interval"] = 1e12;
  const fs::path bench_config = dir / "bench.yaml";
  YAML::Emitter emitter;
  emitter << node;
  std::ofstream(bench_config) << emitter.c_str() << "\n";
  return bench_config;
}

// The group's replicas, replica i on learner_cores[i*threads .. (i+1)*threads - 1] (none given:
// anywhere).
std::vector<std::unique_ptr<Process>> StartLearners(const std::string& ragdoll,
                                                    const fs::path& bench_config,
                                                    const fs::path& dir, const Ports& ports,
                                                    int threads, int replicas,
                                                    const std::vector<int>& learner_cores) {
  std::vector<std::unique_ptr<Process>> learners;
  for (int i = 0; i < replicas; ++i) {
    learners.push_back(std::make_unique<Process>(
        ragdoll,
        RoleArgs("learner", bench_config.string(), ports,
                 {"--run-dir", (dir / "run").string(), "--replicas", std::to_string(replicas),
                  "--index", std::to_string(i)}),
        learner_cores.empty() ? std::vector<int>{}
                              : std::vector<int>(learner_cores.begin() + i * threads,
                                                 learner_cores.begin() + (i + 1) * threads)));
  }
  return learners;
}

// Samples the group has trained, from replica 0's metrics.
double Trained(const Ports& ports) {
  return Scrape(ports.learner_metrics(0), "ragdoll_learner_run_samples");
}

// Segments the group has dropped as stale, over all replicas.
double Stale(const Ports& ports, int replicas) {
  double sum = 0;
  for (int i = 0; i < replicas; ++i) {
    sum += std::max(
        0.0, Scrape(ports.learner_metrics(i), "ragdoll_learner_stale_segments_dropped_total"));
  }
  return sum;
}

double CpuSeconds(const std::vector<std::unique_ptr<Process>>& processes) {
  double c = 0;
  for (auto& p : processes) c += p->CpuSeconds();
  return c;
}

// The window's figures into `out`: trained samples/s, the stale fraction and the CPU each side
// used; the samples it trained. The window runs from one update's landing to another's, so that
// it holds whole updates only: an update is a large part of the window, and counting from a
// moment in between would be off by up to one update's samples.
double MeasureWindow(const Process& broker, const std::vector<std::unique_ptr<Process>>& learners,
                     const Ports& ports, double seconds, double rate, int time_horizon,
                     nlohmann::json& out) {
  const int replicas = static_cast<int>(learners.size());
  auto next_landing = [&](double after) {
    WaitFor(60, [&] { return Trained(ports) > after; });
    return Clock::now();
  };
  double trained0 = Trained(ports);
  const auto t0 = next_landing(trained0);
  trained0 = Trained(ports);
  const double stale0 = Stale(ports, replicas);
  const double cpu0 = CpuSeconds(learners);
  const double broker_cpu0 = broker.CpuSeconds(), own_cpu0 = OwnCpuSeconds();
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  const double before = Trained(ports);
  next_landing(before);
  const double wall = Since(t0);
  const double cpu = CpuSeconds(learners) - cpu0;
  const double trained_samples = Trained(ports) - trained0;
  const double stale_samples = (Stale(ports, replicas) - stale0) * time_horizon;
  out["offered_samples_per_s"] = rate > 0 ? nlohmann::json(rate) : nlohmann::json("unlimited");
  out["trained_samples_per_s"] = trained_samples / wall;
  out["stale_fraction"] = stale_samples / std::max(1.0, stale_samples + trained_samples);
  out["learner_cpu_cores"] = cpu / wall;
  out["broker_cpu_cores"] = (broker.CpuSeconds() - broker_cpu0) / wall;
  out["synthetic_actors_cpu_cores"] = (OwnCpuSeconds() - own_cpu0) / wall;
  return trained_samples;
}

// Where the window's time went, from replica 0's metrics.csv (its last rows are the window's
// updates): the median update's seconds and the median fraction of an iteration rank 0 spent
// waiting for segments.
void AddUpdateFigures(const fs::path& metrics_csv, double trained_samples, double buffer,
                      nlohmann::json& out) {
  try {
    std::stringstream text;
    text << std::ifstream(metrics_csv).rdbuf();
    const learner::MetricsTable table = learner::ParseMetricsCsv(text.str(), "metrics.csv");
    const std::vector<double>* update_s = table.Column("update_s");
    const std::vector<double>* idle = table.Column("idle_fraction");
    const auto updates =
        std::min(table.rows, static_cast<size_t>(std::lround(trained_samples / buffer)));
    if (update_s != nullptr && idle != nullptr && updates > 0) {
      out["updates"] = updates;
      out["median_update_s"] = Median({update_s->end() - updates, update_s->end()});
      out["median_idle_fraction"] = Median({idle->end() - updates, idle->end()});
    }
  } catch (const std::exception& error) {
    out["metrics_csv_error"] = error.what();
  }
}

// A learner group of `replicas` with `threads` intra-op threads each, offered `rate` samples/s
// (0: more than it can take). Trained samples/s and the stale-drop fraction. Replica i runs on
// learner_cores[i*threads .. (i+1)*threads - 1] (--pin); with none given, anywhere.
nlohmann::json BenchLearner(const std::string& ragdoll, const run::Experiment& e,
                            const Recording& rec, const Ports& ports, double seconds, int threads,
                            int replicas, double rate, int senders,
                            const std::vector<int>& learner_cores) {
  const fs::path dir =
      fs::temp_directory_path() / ("ragdoll-bench-cluster-" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path bench_config = WriteBenchConfig(e, threads, dir);
  Process broker(ragdoll, RoleArgs("broker", bench_config.string(), ports));
  const std::vector<std::unique_ptr<Process>> learners =
      StartLearners(ragdoll, bench_config, dir, ports, threads, replicas, learner_cores);
  nlohmann::json out = {
      {"threads", threads}, {"replicas", replicas}, {"pinned", !learner_cores.empty()}};
  zmq::context_t context(2);
  Replay replay(context, ports.endpoints, rec, senders, rate);
  // Warm up: two updates done, so the group has formed and the first update's set-up is past.
  const double buffer = e.trainer.buffer_size;
  if (!WaitFor(120, [&] { return Trained(ports) >= 2 * buffer; })) {
    out["error"] = "the learner group trained nothing within 120 s";
    return out;
  }
  const double trained_samples =
      MeasureWindow(broker, learners, ports, seconds, rate, rec.time_horizon, out);
  AddUpdateFigures(dir / "run" / "metrics.csv", trained_samples, buffer, out);
  fs::remove_all(dir);
  return out;
}

// One snapshot pushed into the broker as the learner does; the time until every one of
// `subscribers` actor sockets (conflating, as actors subscribe) has it.
nlohmann::json BenchSnapshots(const std::string& ragdoll, const std::string& config,
                              const Recording& rec, const Ports& ports, int subscribers,
                              int repeats) {
  Process broker(ragdoll, RoleArgs("broker", config, ports));
  zmq::context_t context(2);
  std::vector<zmq::socket_t> subs;
  for (int i = 0; i < subscribers; ++i) {
    subs.push_back(MakeSocket(context, zmq::socket_type::sub, ports.endpoints, 0));
    subs.back().set(zmq::sockopt::conflate, 1);
    subs.back().set(zmq::sockopt::subscribe, "");
    subs.back().connect(ports.endpoints.Connect(ports.endpoints.snapshot_port));
  }
  zmq::socket_t push = MakeSocket(context, zmq::socket_type::push, ports.learner);
  push.connect(ports.endpoints.Connect(ports.endpoints.learner_snapshot_port));
  v1::Header header;
  v1::PolicySnapshot snapshot;
  wire::ReadMessage(rec.snapshot.data(), rec.snapshot.size(), ports.endpoints.max_message_bytes,
                    &header, &snapshot);
  std::this_thread::sleep_for(std::chrono::seconds(1));  // every subscription in place
  std::vector<double> times;
  int64_t version = 1;
  for (int r = 0; r < repeats + 1; ++r, ++version) {
    snapshot.set_version(version);
    const std::string message = wire::Pack(v1::KIND_SNAPSHOT, kRun, "learner", snapshot, version);
    std::vector<bool> have(subs.size(), false);
    size_t count = 0;
    const auto t0 = Clock::now();
    Send(push, zmq::buffer(message));
    while (count < subs.size() && Since(t0) < 10) {
      for (size_t i = 0; i < subs.size(); ++i) {
        zmq::message_t m;
        if (have[i] || !subs[i].recv(m, zmq::recv_flags::dontwait)) continue;
        v1::Header h;
        size_t offset = 0;
        if (wire::ReadHeader(m.data(), m.size(), ports.endpoints.max_message_bytes, &h, &offset)
                .ok() &&
            h.policy_version() == version) {
          have[i] = true;
          ++count;
        }
      }
    }
    if (r > 0) times.push_back(count == subs.size() ? Since(t0) : -1);  // the first warms up
  }
  return {{"subscribers", subscribers},
          {"snapshot_bytes", rec.snapshot.size()},
          {"median_s", Median(times)},
          {"max_s", *std::max_element(times.begin(), times.end())}};
}

// Stale-free absorption: the highest offered rate at which under 1 % of the segments go stale.
// Searched from 0.9 of the flooded rate, up by 10 % while it passes (a flood slows the learners
// it floods: they parse segments only to drop them, beside a broker forwarding twice what they
// train on, so they may absorb more than they train flooded), down by 15 % while it fails, then
// once halfway between the last pass and the first failure. The figure is the best absorption
// among the runs that passed.
nlohmann::json Absorption(const std::string& ragdoll, const run::Experiment& e,
                          const Recording& rec, const Ports& ports, double seconds, int threads,
                          int replicas, int senders, const std::vector<int>& learner_cores,
                          const nlohmann::json& flood, double lowest_start) {
  const double flooded = flood["trained_samples_per_s"].get<double>();
  // A run passes when under 1 % of its segments went stale and the group kept pace: it trained
  // at least 95 % of what it was offered. A group that trains less has a growing queue, whose
  // segments go stale later than a window of 15-20 s shows.
  auto passes = [](const nlohmann::json& run) {
    return !run.contains("error") && run.value("stale_fraction", 1.0) < 0.01 &&
           run.value("trained_samples_per_s", 0.0) >=
               0.95 * run["offered_samples_per_s"].get<double>();
  };
  auto offer = [&](double rate) {
    return BenchLearner(ragdoll, e, rec, ports, seconds, threads, replicas, rate, senders,
                        learner_cores);
  };
  // A run's absorption is what was both offered and trained: a run may also train a
  // backlog queued before its window, and trains at most its capacity when offered more.
  auto absorbed_by = [](const nlohmann::json& run) {
    return std::min(run["offered_samples_per_s"].get<double>(),
                    run["trained_samples_per_s"].get<double>());
  };
  nlohmann::json paced, tried = nlohmann::json::array();
  double absorbed = 0;
  auto try_rate = [&](double r) {
    nlohmann::json run = offer(r);
    tried.push_back(run);
    const bool ok = passes(run);
    if (ok && absorbed_by(run) > absorbed) {
      absorbed = absorbed_by(run);
      paced = run;
    }
    return ok;
  };
  // From 90 % of the flooded rate, or `lowest_start` when higher (a group of replicas floods
  // far below what it absorbs: the broker's pushing takes the replicas' cores), up by 10 % or
  // down by 15 % until one rate passes and another fails (at most 8 runs), then the gap
  // between them halved twice.
  double passed = 0, failed = 0, rate = std::max(0.9 * flooded, lowest_start);
  for (int i = 0; i < 8 && (passed == 0 || failed == 0); ++i) {
    if (try_rate(rate)) {
      passed = rate;
      rate *= 1.1;
    } else {
      failed = rate;
      rate *= 0.85;
    }
  }
  for (int i = 0; i < 2 && passed > 0 && failed > 0; ++i) {
    const double middle = 0.5 * (passed + failed);
    (try_rate(middle) ? passed : failed) = middle;
  }
  if (paced.is_null()) paced = tried.back();
  paced["fraction_of_flooded"] =
      paced.value("offered_samples_per_s", nlohmann::json(0.0)).get<double>() / flooded;
  paced["absorbed_samples_per_s"] = absorbed;
  return {{"flooded", flood}, {"paced", paced}, {"tried", tried}};
}

std::vector<int> Numbers(const std::string& list) {
  std::vector<int> out;
  std::stringstream in(list);
  for (std::string item; std::getline(in, item, ',');) out.push_back(std::stoi(item));
  return out;
}

struct BenchOptions {
  std::string config, json_out, threads_list = "1,2", replicas_list = "1,2", harness_list;
  std::string ragdoll = (fs::canonical("/proc/self/exe").parent_path() / "ragdoll").string();
  double seconds = 20;
  int subscribers = 100, senders = 2, port_base = 27000, repeats = 1;
  bool pin = false, curve = false;
};

// The learners' cores: under --pin the first ones (replica i of T threads: i*T .. i*T+T-1,
// wrapping on a small machine), and --harness-cores must lie beyond them; without --pin none
// (they float).
std::vector<int> LearnerCores(const BenchOptions& o, const std::vector<int>& harness) {
  const int cores = static_cast<int>(std::thread::hardware_concurrency());
  if (!harness.empty() && !o.pin) {
    throw std::runtime_error("--harness-cores needs --pin, so that the learners' cores are known");
  }
  std::vector<int> learner_cores;
  if (!o.pin) return learner_cores;
  int widest = 1;  // the most cores one learner group asks for
  for (int t : Numbers(o.threads_list)) widest = std::max(widest, t);
  for (int r : Numbers(o.replicas_list)) widest = std::max(widest, r);
  for (int c = 0; c < widest; ++c) learner_cores.push_back(c % cores);
  for (int c : harness) {
    if (c < 0 || c >= cores) {
      throw std::runtime_error("--harness-cores: no core " + std::to_string(c) +
                               " (this machine has " + std::to_string(cores) + ")");
    }
    if (c < widest) {
      throw std::runtime_error("--harness-cores: core " + std::to_string(c) +
                               " is a learner's under --pin (cores 0-" +
                               std::to_string(widest - 1) + "); this needs at least " +
                               std::to_string(widest + 1) + " cores");
    }
  }
  return learner_cores;
}

// --curve: fresh keys for every role beside the ragdoll binary; the folder ("" for plaintext).
std::string MakeKeys(const BenchOptions& o) {
  if (!o.curve) return "";
  const std::string keys = (fs::path(o.ragdoll).parent_path() / "bench-cluster-keys").string();
  fs::remove_all(keys);
  for (const char* role : {"broker", "actor", "learner"}) {
    const KeyPaths paths = KeyPathsOf(keys, role, role);
    SaveCertificate(NewCertificate(role, role), paths.public_key, paths.secret_key);
  }
  return keys;
}

void BrokerFigures(const BenchOptions& o, const Recording& rec, const Ports& ports,
                   nlohmann::json& result) {
  nlohmann::json broker = BenchBroker(o.ragdoll, o.config, rec, ports, o.seconds, o.senders);
  result["broker"] = broker;
  std::printf(
      "broker ceiling (sink as learner)  %8.0f segments/s  %9.0f samples/s  %7.1f MB/s  "
      "broker CPU %.2f cores  -> %.0f samples/s per broker core\n",
      broker["segments_per_s"].get<double>(), broker["samples_per_s"].get<double>(),
      broker["MB_per_s"].get<double>(), broker["broker_cpu_cores"].get<double>(),
      broker["samples_per_s_per_broker_core"].get<double>());
  std::fflush(stdout);
}

// One group's line: flooded, then its stale-free absorption and where the CPU went there.
void PrintAbsorption(int threads, int replicas, const nlohmann::json& flood,
                     const nlohmann::json& paced, double ratio) {
  std::printf(
      "learner %d thread(s) x %d replica(s)  flooded: %7.0f samples/s trained, stale %.3f, "
      "CPU %.2f cores | absorbs %7.0f samples/s stale-free (offered %.0f: trained %.0f, "
      "stale %.4f, CPU %.2f cores; broker %.3f, synthetic actors %.3f; update %.2f s, "
      "idle %.0f %%)",
      threads, replicas, flood["trained_samples_per_s"].get<double>(),
      flood["stale_fraction"].get<double>(), flood["learner_cpu_cores"].get<double>(),
      paced["absorbed_samples_per_s"].get<double>(),
      paced.value("offered_samples_per_s", nlohmann::json(0.0)).get<double>(),
      paced.value("trained_samples_per_s", 0.0), paced.value("stale_fraction", -1.0),
      paced.value("learner_cpu_cores", 0.0), paced.value("broker_cpu_cores", 0.0),
      paced.value("synthetic_actors_cpu_cores", 0.0), paced.value("median_update_s", 0.0),
      100 * paced.value("median_idle_fraction", 0.0));
  if (ratio > 0) std::printf(" = %.2f x one replica", ratio);
  std::printf("\n");
  std::fflush(stdout);
}

// Absorbed samples/s by (threads, replicas), and each replica group's ratios to one replica in
// the same round, by replica count.
struct Rounds {
  std::map<std::pair<int, int>, std::vector<double>> absorbed;
  std::map<int, std::vector<double>> ratios;
};

// With --repeats: each group's median absorption and median ratio to one replica.
void PrintMedians(const Rounds& rounds, nlohmann::json& result) {
  result["median_absorbed_samples_per_s"] = nlohmann::json::array();
  for (auto& [group, values] : rounds.absorbed) {
    std::printf("learner %d thread(s) x %d replica(s)  absorbs %7.0f samples/s (median of %zu)",
                group.first, group.second, Median(values), values.size());
    result["median_absorbed_samples_per_s"].push_back(
        {{"threads", group.first}, {"replicas", group.second}, {"median", Median(values)}});
    if (rounds.ratios.count(group.second) > 0 && group.second > 1) {
      const std::vector<double>& r = rounds.ratios.at(group.second);
      std::printf(", %.2f x one replica (median of %zu rounds' ratios, %.2f-%.2f)", Median(r),
                  r.size(), *std::min_element(r.begin(), r.end()),
                  *std::max_element(r.begin(), r.end()));
      result["median_ratio_to_one_replica"][std::to_string(group.second)] = Median(r);
    }
    std::printf("\n");
  }
}

// Each learner group flooded, then its absorption searched; --repeats rounds of all groups in
// turn (1, 2, 1, 2, ...), so that a replica group's ratio to one replica compares runs minutes
// apart, not a whole search apart: the machines drift within an hour (docs/learner-scaling.md).
void LearnerFigures(const BenchOptions& o, const run::Experiment& e, const Recording& rec,
                    const Ports& ports, const std::vector<int>& learner_cores,
                    nlohmann::json& result) {
  std::vector<std::pair<int, int>> groups;
  for (int t : Numbers(o.threads_list)) groups.emplace_back(t, 1);
  for (int r : Numbers(o.replicas_list)) {
    if (r > 1) groups.emplace_back(1, r);
  }
  result["learner"] = nlohmann::json::array();
  Rounds rounds;
  for (int round = 0; round < o.repeats; ++round) {
    double one_replica = 0;
    for (const auto& group : groups) {
      const int threads = group.first;
      const int replicas = group.second;
      nlohmann::json flood = BenchLearner(o.ragdoll, e, rec, ports, o.seconds, threads, replicas, 0,
                                          o.senders, learner_cores);
      if (flood.contains("error")) {
        std::printf("learner %d thread(s) x %d replica(s): %s\n", threads, replicas,
                    flood["error"].get<std::string>().c_str());
        result["learner"].push_back(flood);
        continue;
      }
      // A replica group's search starts no lower than 77 % (0.9 x 0.85) of linear scaling of
      // this round's one replica.
      const double lowest_start = replicas > 1 ? 0.9 * 0.85 * replicas * one_replica : 0;
      nlohmann::json run = Absorption(o.ragdoll, e, rec, ports, o.seconds, threads, replicas,
                                      o.senders, learner_cores, flood, lowest_start);
      run["round"] = round;
      const double absorbed = run["paced"]["absorbed_samples_per_s"].get<double>();
      rounds.absorbed[group].push_back(absorbed);
      if (threads == 1 && replicas == 1) one_replica = absorbed;
      const double ratio = replicas > 1 && one_replica > 0 ? absorbed / one_replica : 0;
      if (ratio > 0) rounds.ratios[replicas].push_back(ratio);
      PrintAbsorption(threads, replicas, flood, run["paced"], ratio);
      result["learner"].push_back(run);
    }
  }
  if (o.repeats > 1) PrintMedians(rounds, result);
}

void SnapshotFigures(const BenchOptions& o, const Recording& rec, const Ports& ports,
                     nlohmann::json& result) {
  nlohmann::json snapshots = BenchSnapshots(o.ragdoll, o.config, rec, ports, o.subscribers, 10);
  result["snapshots"] = snapshots;
  std::printf("snapshot (%zu bytes) to %d subscribers: median %.4f s, max %.4f s\n",
              rec.snapshot.size(), o.subscribers, snapshots["median_s"].get<double>(),
              snapshots["max_s"].get<double>());
}

int Run(const BenchOptions& o) {
  const std::vector<int> harness =
      o.harness_list.empty() ? std::vector<int>{} : Numbers(o.harness_list);
  const std::vector<int> learner_cores = LearnerCores(o, harness);
  if (!harness.empty()) PinTo(harness);
  run::Experiment e = run::ReadExperiment(o.config);
  const Ports ports = MakePorts(o.port_base, e.broker.endpoints, MakeKeys(o));
  const int buffer_segments = static_cast<int>(e.trainer.buffer_size / e.trainer.time_horizon) + 1;
  std::fprintf(stderr, "recording %d segments from %s ...\n", buffer_segments, o.config.c_str());
  const Recording rec = Record(e, buffer_segments);
  nlohmann::json result = {{"config", o.config},
                           {"curve", o.curve},
                           {"cores", std::thread::hardware_concurrency()},
                           {"bytes_per_sample", rec.bytes_per_sample},
                           {"time_horizon", rec.time_horizon},
                           {"pin", o.pin},
                           {"harness_cores", harness}};
  std::printf("cluster benchmark (%s, %u cores, %.0f bytes per sample on the wire, %s)\n",
              o.config.c_str(), std::thread::hardware_concurrency(), rec.bytes_per_sample,
              o.curve ? "CURVE" : "plaintext");
  BrokerFigures(o, rec, ports, result);
  LearnerFigures(o, e, rec, ports, learner_cores, result);
  SnapshotFigures(o, rec, ports, result);
  if (!o.json_out.empty()) std::ofstream(o.json_out) << result.dump(2) << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  ragdoll::blas::ChooseKernels(argv);
  ragdoll::allocator::KeepLargeBlocks();
  CLI::App app("Broker ceiling, learner absorption and snapshot fan-out on loopback.");
  BenchOptions o;
  app.add_option("config", o.config, "experiment YAML")->required();
  app.add_option("--ragdoll", o.ragdoll, "the ragdoll binary")->capture_default_str();
  app.add_option("--seconds", o.seconds, "measuring window per figure")->capture_default_str();
  app.add_option("--threads", o.threads_list, "learner thread counts (1 replica)")
      ->capture_default_str();
  app.add_option("--replicas", o.replicas_list, "learner replica counts (1 thread each)")
      ->capture_default_str();
  app.add_option("--subscribers", o.subscribers, "actors subscribed to snapshots")
      ->capture_default_str();
  app.add_option("--repeats", o.repeats,
                 "run the learner groups in turn this many times; medians, and each replica "
                 "group's median ratio to one replica in the same round")
      ->capture_default_str()
      ->check(CLI::Range(1, 20));
  app.add_option("--senders", o.senders, "synthetic actor threads")->capture_default_str();
  app.add_option("--port-base", o.port_base, "ports PORT_BASE..PORT_BASE+60")
      ->capture_default_str();
  app.add_option("--json", o.json_out, "also write the figures here");
  app.add_flag("--pin", o.pin,
               "pin learner replica i of T threads to cores i*T..i*T+T-1 (the broker and the "
               "synthetic actors float unless --harness-cores), so that each replica has cores "
               "of its own");
  app.add_option("--harness-cores", o.harness_list,
                 "cores for the broker, the synthetic actors and this process (e.g. 2 or 2,3), "
                 "none of the learners' under --pin: on a machine with cores to spare, the "
                 "learners then share theirs with nothing of the benchmark's");
  app.add_flag("--curve", o.curve,
               "every socket on CURVE (keys made in build/bench-cluster-keys), to compare with a "
               "plaintext run");
  CLI11_PARSE(app, argc, argv);
  try {
    return Run(o);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "ragdoll-bench-cluster: %s\n", error.what());
    return 1;
  }
}
