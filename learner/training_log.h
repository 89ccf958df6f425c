// What the learner process reports of its training: a progress line per update on stdout, a row of
// the run's metrics.csv, and the Prometheus series. Replica 0 (the leader) writes the line and the
// CSV and counts the group's totals; every replica sets its own gauges.
#pragma once

#include <chrono>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "common/metrics.h"
#include "common/wire.h"
#include "learner/learner.h"
#include "learner/metrics_csv.h"

namespace ragdoll::learner {

struct LearnerMetrics;

class TrainingLog {
 public:
  // Opens (appends to) `run_dir`/metrics.csv on the leader, writing its header when new (a resumed
  // run keeps its file's columns); the elapsed time, rates and totals count from here and from
  // `learner`'s state now. The learner's episode figures (EpisodeStatsSum::figure_names) are
  // columns and gauges, the first `reward_terms` of them reward terms.
  TrainingLog(MetricsEndpoint& endpoint, const std::string& run_dir, const std::string& label,
              bool leader, const Learner& learner, int reward_terms);
  ~TrainingLog();

  // A segment dropped for `verdict`: counted by reason, logged once in a hundred.
  void Rejected(const wire::Verdict& verdict);
  // A segment taken `lag` versions behind the learner; `stale_dropped` is the learner's total.
  void Accepted(int64_t lag);
  void CountStale(int64_t stale_dropped);
  // Time spent waiting for a segment.
  void Idle(double seconds);
  // After an update: the progress line, the gauges and the CSV row.
  void Updated(const Learner& learner, const UpdateStats& u, int64_t max_steps);
  void CheckpointWritten(const char* why, const std::string& path);
  void CheckpointFailed(const char* why, const std::string& error);
  // The one-thread figures measured at start-up: the BLAS's sgemm (published) and the same
  // networks' plain fwd+bwd+Adam; updates that run far below the latter per CPU-second are warned
  // of (oversubscribed threads, a busy machine).
  void CompareUpdatesWith(double sgemm_gflops, double raw_gflops);

 private:
  using Clock = std::chrono::steady_clock;

  // Updated's parts that keep state: the update's speed judged against raw_gflops_ (warned of
  // when slow), and the leader's CSV row.
  void JudgeUpdateRate(const UpdateStats& u);
  void WriteCsvRow(const Learner& learner, const EpisodeStatsSum& e, const UpdateStats& u,
                   double elapsed, double iteration_s, double idle_fraction);

  std::unique_ptr<LearnerMetrics> metrics_;
  std::string label_;
  bool leader_;
  std::ofstream csv_;
  std::vector<std::string> csv_columns_;
  const Clock::time_point start_ = Clock::now();
  Clock::time_point last_iteration_ = start_;
  int64_t start_samples_, start_stale_;
  int64_t rejected_total_ = 0;
  double idle_seconds_ = 0;  // waiting for segments since the last update
  double raw_gflops_ = 0;
  int64_t updates_ = 0;       // judged since start-up
  int64_t slow_updates_ = 0;  // in a row, below kSlowUpdate of raw_gflops_
};

}  // namespace ragdoll::learner
