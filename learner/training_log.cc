#include "learner/training_log.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <vector>

namespace ragdoll::learner {
namespace fs = std::filesystem;
namespace {

// An update whose products run below this share of the same network's plain fwd+bwd+Adam (one
// thread, at start-up) per CPU-second is far below the machine: docs/tools.md has the ratios.
constexpr double kSlowUpdate = 0.25;
constexpr int64_t kSlowWarnEvery = 50;  // updates between repeated warnings

std::string Duration(double seconds) {
  if (!(seconds >= 0) || seconds > 1e8) return "--:--:--";
  long s = static_cast<long>(seconds);
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
  return buffer;
}

// A value as the metrics.csv writes it (an ostream's default format).
template <typename T>
std::string Cell(T value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

}  // namespace

// The learner's Prometheus series. Episode and PPO figures are gauges holding the latest PPO
// iteration's means; totals are counters of this process (a resumed run's totals are gauges).
struct LearnerMetrics {
  LearnerMetrics(MetricsEndpoint& m, const std::vector<std::string>& figure_names, int reward_terms)
      : episode_return(
            m.Gauge("ragdoll_episode_return",
                    "Mean undiscounted return of the episodes of the last PPO iteration")),
        normalized_return(m.Gauge("ragdoll_episode_normalized_return",
                                  "Mean return per step relative to the maximum (0..1) of the "
                                  "episodes of the last PPO iteration")),
        episode_length(m.Gauge("ragdoll_episode_length_steps",
                               "Mean episode length in control steps, last PPO iteration")),
        fall_ratio(m.Gauge("ragdoll_episode_fall_ratio",
                           "Fraction of the last PPO iteration's episodes that ended in a fall")),
        episodes(m.Counter("ragdoll_episodes_total", "Episodes finished by all actors")),
        policy_loss(m.Gauge("ragdoll_ppo_policy_loss", "Clipped surrogate loss, last update")),
        value_loss(m.Gauge("ragdoll_ppo_value_loss", "Value loss, last update")),
        entropy(m.Gauge("ragdoll_ppo_entropy", "Policy entropy (nats), last update")),
        approx_kl(m.Gauge("ragdoll_ppo_approx_kl", "Approximate KL divergence, last update")),
        clip_fraction(m.Gauge("ragdoll_ppo_clip_ratio",
                              "Fraction of samples whose ratio was clipped, last update")),
        explained_variance(m.Gauge("ragdoll_ppo_explained_variance",
                                   "Explained variance of the value targets, last update")),
        learning_rate(m.Gauge("ragdoll_ppo_learning_rate", "Adam learning rate")),
        updates(m.Counter("ragdoll_ppo_updates_total", "PPO updates run by this learner process")),
        update_seconds(m.Histogram("ragdoll_ppo_update_duration_seconds",
                                   "Wall time of one PPO update (all epochs)",
                                   {0.25, 0.5, 1, 2, 4, 8, 16, 32, 64})),
        skipped_steps(m.Counter("ragdoll_ppo_skipped_gradient_steps_total",
                                "Gradient steps skipped for a non-finite gradient")),
        samples(m.Counter(
            "ragdoll_learner_samples_total",
            "Samples trained on by this learner process (by its group: counted by replica 0)")),
        run_samples(m.Gauge("ragdoll_learner_run_samples",
                            "Samples trained on in the whole run (continues after a resume)")),
        samples_per_second(m.Gauge("ragdoll_learner_samples_per_second",
                                   "Samples per second over the last PPO iteration")),
        version(m.Gauge("ragdoll_policy_version", "Version of the newest policy")),
        lag(m.Histogram("ragdoll_learner_policy_lag_versions",
                        "Policy versions between a segment's behaviour policy and the learner's",
                        {0, 1, 2, 3, 5, 10, 20})),
        stale(m.Counter("ragdoll_learner_stale_segments_dropped_total",
                        "Segments dropped for exceeding max_policy_lag")),
        checkpoints(m.Counter("ragdoll_learner_checkpoints_total", "Checkpoints written")),
        checkpoint_failures(m.Counter("ragdoll_learner_checkpoint_failures_total",
                                      "Checkpoints that could not be written (full disk, file size "
                                      "limit); training went on")),
        idle_seconds(m.Counter("ragdoll_learner_idle_seconds_total",
                               "Wall time spent waiting for segments (nothing to do)")),
        update_gflops(m.Gauge("ragdoll_learner_update_gflops",
                              "The last update's matrix products (6 per weight per sample) per "
                              "CPU-second of this process")),
        sgemm_gflops(m.Gauge("ragdoll_blas_sgemm_gflops",
                             "One-thread sgemm rate measured at start-up: the BLAS's limit")),
        raw_gflops(m.Gauge("ragdoll_learner_raw_gflops",
                           "The same networks' plain forward+backward+Adam on one thread, measured "
                           "at start-up: the update's limit")) {
    for (int i = 0; i < static_cast<int>(figure_names.size()); ++i) {
      figures.push_back(
          i < reward_terms
              ? &m.Gauge("ragdoll_episode_reward_term",
                         "Mean per-step value (0..1) of one reward term (the imitation terms and a "
                         "task's weighted term), last PPO iteration",
                         {{"term", figure_names[i]}})
              : &m.Gauge("ragdoll_episode_figure",
                         "Mean per-step value of one of a task's episode figures (steering: "
                         "speed_error in m/s, heading_error in rad), last PPO iteration",
                         {{"figure", figure_names[i]}}));
    }
    for (int r = 1; r <= static_cast<int>(wire::Rejection::kRunId); ++r) {
      rejected.push_back(&m.Counter(
          "ragdoll_learner_rejected_messages_total", "Messages dropped by the learner, by reason",
          {{"reason", wire::RejectionName(static_cast<wire::Rejection>(r))}}));
    }
  }

  prometheus::Gauge &episode_return, &normalized_return, &episode_length, &fall_ratio;
  prometheus::Counter& episodes;
  prometheus::Gauge &policy_loss, &value_loss, &entropy, &approx_kl, &clip_fraction,
      &explained_variance, &learning_rate;
  prometheus::Counter& updates;
  prometheus::Histogram& update_seconds;
  prometheus::Counter &skipped_steps, &samples;
  prometheus::Gauge &run_samples, &samples_per_second, &version;
  prometheus::Histogram& lag;
  prometheus::Counter &stale, &checkpoints, &checkpoint_failures, &idle_seconds;
  prometheus::Gauge &update_gflops, &sgemm_gflops, &raw_gflops;
  std::vector<prometheus::Gauge*> figures;     // as the learner's figure names
  std::vector<prometheus::Counter*> rejected;  // index: Rejection - 1
};

TrainingLog::TrainingLog(MetricsEndpoint& endpoint, const std::string& run_dir,
                         const std::string& label, bool leader, const Learner& learner,
                         int reward_terms)
    : metrics_(std::make_unique<LearnerMetrics>(endpoint, learner.episodes().figure_names,
                                                reward_terms)),
      label_(label),
      leader_(leader),
      start_samples_(learner.samples()),
      start_stale_(learner.stale_dropped()) {
  LearnerMetrics& metrics = *metrics_;
  metrics.version.Set(static_cast<double>(learner.version()));
  metrics.run_samples.Set(static_cast<double>(learner.samples()));
  const fs::path csv_path = fs::path(run_dir) / kMetricsFile;
  if (!leader) return;
  // A resumed run keeps its file's columns (an older learner's order or figures); a new one has the
  // fixed columns, then a column per episode figure.
  if (fs::exists(csv_path)) csv_columns_ = ReadMetricsHeader(csv_path.string());
  const bool new_csv = csv_columns_.empty();
  if (new_csv) csv_columns_ = MetricsColumns(learner.episodes().figure_names);
  csv_.open(csv_path, std::ios::app);
  if (new_csv) csv_ << MetricsHeader(csv_columns_) << "\n";
}

TrainingLog::~TrainingLog() = default;

void TrainingLog::Rejected(const wire::Verdict& v) {
  metrics_->rejected[static_cast<int>(v.rejection) - 1]->Increment();
  if (rejected_total_++ % 100 == 0) {
    std::fprintf(stderr, "learner: dropped a segment (%s): %s [%lld dropped so far]\n",
                 wire::RejectionName(v.rejection), v.detail.c_str(),
                 static_cast<long long>(rejected_total_));
  }
}

void TrainingLog::Accepted(int64_t lag) { metrics_->lag.Observe(static_cast<double>(lag)); }

void TrainingLog::CountStale(int64_t stale_dropped) {
  AdvanceTo(metrics_->stale, static_cast<double>(stale_dropped - start_stale_));
}

void TrainingLog::Idle(double waited) {
  idle_seconds_ += waited;
  metrics_->idle_seconds.Increment(waited);
}

namespace {

// The progress line (the leader's).
void PrintProgress(const std::string& label, const Learner& learner, const EpisodeStatsSum& e,
                   const UpdateStats& u, double rate, double idle_fraction, double elapsed,
                   double eta) {
  std::printf(
      "[%s] it %lld  samples %lld  %.0f/s  return %.2f  norm %.3f  len %.1f  fall %.2f  v%lld  "
      "kl %.4f  idle %.0f%%  elapsed %s  eta %s\n",
      label.c_str(), static_cast<long long>(learner.iterations()),
      static_cast<long long>(learner.samples()), rate, e.Mean(e.episode_return),
      e.Mean(e.normalized_return), e.Mean(e.length), e.Mean(e.falls),
      static_cast<long long>(learner.version()), u.approx_kl, 100 * idle_fraction,
      Duration(elapsed).c_str(), Duration(eta).c_str());
}

// The episode gauges, and the episode total.
void SetEpisodeMetrics(LearnerMetrics& metrics, const EpisodeStatsSum& e, bool leader) {
  metrics.episode_return.Set(e.Mean(e.episode_return));
  metrics.normalized_return.Set(e.Mean(e.normalized_return));
  metrics.episode_length.Set(e.Mean(e.length));
  metrics.fall_ratio.Set(e.Mean(e.falls));
  // Totals are the group's: replica 0 counts them, so sums over replicas stay right.
  if (leader) metrics.episodes.Increment(static_cast<double>(e.episodes));
  for (size_t i = 0; i < metrics.figures.size(); ++i) metrics.figures[i]->Set(e.Mean(e.figures[i]));
}

// The PPO update's gauges, count and duration.
void SetUpdateMetrics(LearnerMetrics& metrics, const UpdateStats& u) {
  metrics.policy_loss.Set(u.policy_loss);
  metrics.value_loss.Set(u.value_loss);
  metrics.entropy.Set(u.entropy);
  metrics.approx_kl.Set(u.approx_kl);
  metrics.clip_fraction.Set(u.clip_fraction);
  metrics.explained_variance.Set(u.explained_variance);
  metrics.learning_rate.Set(u.learning_rate);
  metrics.updates.Increment();
  metrics.update_seconds.Observe(u.seconds);
}

}  // namespace

void TrainingLog::Updated(const Learner& learner, const UpdateStats& u, int64_t max_steps) {
  LearnerMetrics& metrics = *metrics_;
  const bool leader = leader_;
  const EpisodeStatsSum& e = learner.episodes();
  double elapsed = std::chrono::duration<double>(Clock::now() - start_).count();
  double iteration_s = std::chrono::duration<double>(Clock::now() - last_iteration_).count();
  last_iteration_ = Clock::now();
  double rate = (learner.samples() - start_samples_) / std::max(elapsed, 1e-9);
  const double idle_fraction = idle_seconds_ / std::max(iteration_s, 1e-9);
  idle_seconds_ = 0;
  double eta = (max_steps - learner.samples()) / std::max(rate, 1e-9);
  if (leader) PrintProgress(label_, learner, e, u, rate, idle_fraction, elapsed, eta);
  std::fflush(stdout);
  SetEpisodeMetrics(metrics, e, leader);
  SetUpdateMetrics(metrics, u);
  JudgeUpdateRate(u);
  metrics.skipped_steps.Increment(static_cast<double>(u.skipped_steps));
  if (leader) metrics.samples.Increment(static_cast<double>(u.samples));
  metrics.run_samples.Set(static_cast<double>(learner.samples()));
  metrics.samples_per_second.Set(u.samples / std::max(iteration_s, 1e-9));
  metrics.version.Set(static_cast<double>(learner.version()));
  if (leader) WriteCsvRow(learner, e, u, elapsed, iteration_s, idle_fraction);
}

void TrainingLog::JudgeUpdateRate(const UpdateStats& u) {
  LearnerMetrics& metrics = *metrics_;
  if (u.cpu_seconds > 0) {
    const double gflops = u.gflop / u.cpu_seconds;
    metrics.update_gflops.Set(gflops);
    // The first updates warm caches and the allocator: judged from the third on.
    if (raw_gflops_ > 0 && ++updates_ >= 3 && gflops < kSlowUpdate * raw_gflops_) {
      if (slow_updates_++ % kSlowWarnEvery == 0) {
        std::fprintf(stderr,
                     "learner: warning: the update ran %.1f GFLOP/s per CPU-second, %.2f of the "
                     "same networks' plain fwd+bwd+Adam on one thread (%.1f): more threads than "
                     "cores, or a busy machine? `ragdoll doctor` measures both halves\n",
                     gflops, gflops / raw_gflops_, raw_gflops_);
      }
    } else {
      slow_updates_ = 0;
    }
  }
}

void TrainingLog::WriteCsvRow(const Learner& learner, const EpisodeStatsSum& e,
                              const UpdateStats& u, double elapsed, double iteration_s,
                              double idle_fraction) {
  std::ofstream& csv = csv_;
  std::map<std::string, std::string> row = {
      {"iteration", Cell(learner.iterations())},
      {"version", Cell(learner.version())},
      {"samples", Cell(learner.samples())},
      {"elapsed_s", Cell(elapsed)},
      {"samples_per_s", Cell(u.samples / std::max(iteration_s, 1e-9))},
      {"episodes", Cell(e.episodes)},
      {"mean_return", Cell(e.Mean(e.episode_return))},
      {"normalized_return", Cell(e.Mean(e.normalized_return))},
      {"episode_length", Cell(e.Mean(e.length))},
      {"fall_rate", Cell(e.Mean(e.falls))},
      {"policy_loss", Cell(u.policy_loss)},
      {"value_loss", Cell(u.value_loss)},
      {"entropy", Cell(u.entropy)},
      {"approx_kl", Cell(u.approx_kl)},
      {"clip_fraction", Cell(u.clip_fraction)},
      {"explained_variance", Cell(u.explained_variance)},
      {"learning_rate", Cell(u.learning_rate)},
      {"update_s", Cell(u.seconds)},
      {"stale_dropped", Cell(learner.stale_dropped())},
      {"rejected", Cell(rejected_total_)},
      {"idle_fraction", Cell(idle_fraction)},
      {"update_kl", Cell(u.update_kl)}};
  for (size_t i = 0; i < e.figures.size(); ++i) row[e.figure_names[i]] = Cell(e.Mean(e.figures[i]));
  csv << MetricsRow(csv_columns_, row) << "\n";
  csv.flush();
}

void TrainingLog::CompareUpdatesWith(double sgemm_gflops, double raw_gflops) {
  raw_gflops_ = raw_gflops;
  metrics_->sgemm_gflops.Set(sgemm_gflops);
  metrics_->raw_gflops.Set(raw_gflops);
}

void TrainingLog::CheckpointWritten(const char* why, const std::string& path) {
  metrics_->checkpoints.Increment();
  std::fprintf(stderr, "learner: %s checkpoint %s\n", why, path.c_str());
}

void TrainingLog::CheckpointFailed(const char* why, const std::string& error) {
  metrics_->checkpoint_failures.Increment();
  std::fprintf(stderr, "learner: %s checkpoint FAILED: %s [%lld failures so far]\n", why,
               error.c_str(), static_cast<long long>(metrics_->checkpoint_failures.Value()));
}

}  // namespace ragdoll::learner
