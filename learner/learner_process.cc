#include "learner/learner_process.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <vector>

#include "common/config_section.h"
#include "common/wire.h"
#include "learner/learner.h"

namespace ragdoll::learner {
namespace fs = std::filesystem;
namespace {

using Clock = std::chrono::steady_clock;

std::string Duration(double seconds) {
  if (!(seconds >= 0) || seconds > 1e8) return "--:--:--";
  long s = static_cast<long>(seconds);
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
  return buffer;
}

std::vector<fs::path> Checkpoints(const fs::path& folder) {
  std::vector<fs::path> out;
  if (!fs::is_directory(folder)) return out;
  for (const auto& entry : fs::directory_iterator(folder)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("checkpoint-", 0) == 0 && entry.path().extension() == ".pt") {
      out.push_back(entry.path());
    }
  }
  std::sort(out.begin(), out.end());  // names carry zero-padded sample counts
  return out;
}

}  // namespace

std::string FindCheckpoint(const std::string& run_or_checkpoint) {
  fs::path p(run_or_checkpoint);
  if (fs::is_regular_file(p)) return p.string();
  auto all = Checkpoints(p / "checkpoints");
  return all.empty() ? "" : all.back().string();
}

int RunLearner(const TrainerConfig& trainer, const LearnerProcessConfig& config,
               const Endpoints& endpoints, const std::atomic<bool>& stop) {
  at::set_num_threads(trainer.threads);
  torch::manual_seed(trainer.seed);
  Learner learner(trainer, config.observation_size, config.action_size);
  const fs::path checkpoints = fs::path(config.run_dir) / "checkpoints";
  fs::create_directories(checkpoints);

  if (config.resume) {
    std::string path = FindCheckpoint(config.run_dir);
    if (path.empty()) {
      std::fprintf(stderr, "learner: --resume: no checkpoint in %s; starting fresh\n",
                   checkpoints.c_str());
    } else {
      learner.Load(path);
      std::fprintf(stderr, "learner: resumed from %s at policy v%lld, %lld samples\n", path.c_str(),
                   static_cast<long long>(learner.version()),
                   static_cast<long long>(learner.samples()));
    }
  } else if (!config.init_from.empty()) {
    std::string path = FindCheckpoint(config.init_from);
    if (path.empty()) throw ConfigError(config.init_from + ": no checkpoint found");
    learner.LoadWeights(path);
    std::fprintf(stderr, "learner: initialised weights from %s\n", path.c_str());
  }

  auto save = [&](const char* why) {
    char name[64];
    std::snprintf(name, sizeof(name), "checkpoint-%012lld.pt",
                  static_cast<long long>(learner.samples()));
    fs::path path = checkpoints / name;
    learner.Save(path.string(), config.config_text);
    auto all = Checkpoints(checkpoints);
    for (size_t i = 0; i + trainer.keep_checkpoints < all.size(); ++i) fs::remove(all[i]);
    std::fprintf(stderr, "learner: %s checkpoint %s\n", why, path.c_str());
  };

  zmq::context_t context(1);
  zmq::socket_t pull = MakeSocket(context, zmq::socket_type::pull, endpoints);
  zmq::socket_t push = MakeSocket(context, zmq::socket_type::push, endpoints);
  pull.connect(endpoints.Connect(endpoints.learner_port));
  push.connect(endpoints.Connect(endpoints.learner_snapshot_port));

  std::string snapshot;
  auto publish = [&]() { Send(push, zmq::buffer(snapshot), zmq::send_flags::dontwait); };
  auto make_snapshot = [&]() {
    snapshot = wire::Pack(v1::KIND_SNAPSHOT, config.run_id, "learner", learner.Snapshot(),
                          learner.version());
    publish();
  };
  make_snapshot();

  const fs::path csv_path = fs::path(config.run_dir) / "metrics.csv";
  bool new_csv = !fs::exists(csv_path);
  std::ofstream csv(csv_path, std::ios::app);
  if (new_csv) {
    csv << "iteration,version,samples,elapsed_s,samples_per_s,episodes,mean_return,"
           "normalized_return,episode_length,fall_rate,rotation,velocity,end_effector,com,root,"
           "policy_loss,value_loss,entropy,approx_kl,clip_fraction,explained_variance,"
           "learning_rate,update_s,stale_dropped,rejected\n";
  }

  const auto start = Clock::now();
  auto last_publish = start, last_iteration = start;
  const int64_t start_samples = learner.samples();
  int64_t next_checkpoint =
      (learner.samples() / trainer.checkpoint_interval + 1) * trainer.checkpoint_interval;
  std::array<int64_t, 9> rejected{};
  int64_t rejected_total = 0;
  auto reject = [&](const wire::Verdict& v) {
    ++rejected[static_cast<int>(v.rejection)];
    if (rejected_total++ % 100 == 0) {
      std::fprintf(stderr, "learner: dropped a segment (%s): %s [%lld dropped so far]\n",
                   wire::RejectionName(v.rejection), v.detail.c_str(),
                   static_cast<long long>(rejected_total));
    }
  };

  while (!stop.load() && learner.samples() < trainer.max_steps) {
    zmq::message_t message;
    if (Receive(pull, message)) {
      v1::Header header;
      v1::TrajectorySegment segment;
      wire::Verdict v = wire::ReadMessage(message.data(), message.size(),
                                          endpoints.max_message_bytes, &header, &segment);
      if (v.ok() && header.kind() != v1::KIND_TRAJECTORY) {
        v = {wire::Rejection::kKind, "expected a trajectory segment"};
      }
      if (v.ok() && header.run_id() != config.run_id) {
        v = {wire::Rejection::kRunId, "segment of run '" + header.run_id() + "'"};
      }
      if (v.ok()) v = wire::CheckSegment(segment, config.observation_size, config.action_size);
      if (!v.ok()) {
        reject(v);
      } else if (learner.Add(segment) == Learner::Accept::kWrongLength) {
        reject({wire::Rejection::kShape, "segment length differs from time_horizon"});
      }
    }
    if (learner.Ready()) {
      UpdateStats u = learner.Update();
      make_snapshot();
      last_publish = Clock::now();
      const EpisodeStatsSum& e = learner.episodes();
      double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
      double iteration_s = std::chrono::duration<double>(Clock::now() - last_iteration).count();
      last_iteration = Clock::now();
      double rate = (learner.samples() - start_samples) / std::max(elapsed, 1e-9);
      double eta = (trainer.max_steps - learner.samples()) / std::max(rate, 1e-9);
      std::printf(
          "[%s] it %lld  samples %lld  %.0f/s  return %.2f  norm %.3f  len %.1f  fall %.2f  "
          "v%lld  kl %.4f  elapsed %s  eta %s\n",
          config.label.c_str(), static_cast<long long>(learner.iterations()),
          static_cast<long long>(learner.samples()), rate, e.Mean(e.episode_return),
          e.Mean(e.normalized_return), e.Mean(e.length), e.Mean(e.falls),
          static_cast<long long>(learner.version()), u.approx_kl, Duration(elapsed).c_str(),
          Duration(eta).c_str());
      std::fflush(stdout);
      csv << learner.iterations() << "," << learner.version() << "," << learner.samples() << ","
          << elapsed << "," << u.samples / std::max(iteration_s, 1e-9) << "," << e.episodes << ","
          << e.Mean(e.episode_return) << "," << e.Mean(e.normalized_return) << ","
          << e.Mean(e.length) << "," << e.Mean(e.falls) << "," << e.Mean(e.rotation) << ","
          << e.Mean(e.velocity) << "," << e.Mean(e.end_effector) << "," << e.Mean(e.com) << ","
          << e.Mean(e.root) << "," << u.policy_loss << "," << u.value_loss << "," << u.entropy
          << "," << u.approx_kl << "," << u.clip_fraction << "," << u.explained_variance << ","
          << u.learning_rate << "," << u.seconds << "," << learner.stale_dropped() << ","
          << rejected_total << "\n";
      csv.flush();
      learner.ResetEpisodeStats();
      if (learner.samples() >= next_checkpoint) {
        save("saved");
        next_checkpoint += trainer.checkpoint_interval;
      }
    }
    if (std::chrono::duration<double>(Clock::now() - last_publish).count() >
        config.republish_seconds) {
      publish();
      last_publish = Clock::now();
    }
  }
  save(stop.load() ? "final (stopped)" : "final (max_steps reached)");
  return 0;
}

}  // namespace ragdoll::learner
