#include "cli/doctor_command.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <torch/torch.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "cli/experiment.h"
#include "cli/measure.h"
#include "common/blas.h"

namespace ragdoll::cli {
namespace {

struct KernelFigure {
  std::string kernel;  // as the child's library reports it
  std::string asked;   // the OPENBLAS_CORETYPE it was started with; empty: the library's own
  double gflops = 0;
};

// The sgemm figure of another kernel set: this program again with OPENBLAS_CORETYPE set (empty:
// the library's own choice), `doctor --sgemm` printing "KERNEL GFLOPS".
KernelFigure TimeKernel(const std::string& core_type) {
  KernelFigure figure{"", core_type, 0};
  int out[2];
  if (pipe(out) != 0) return figure;
  const pid_t pid = fork();
  if (pid == 0) {
    dup2(out[1], STDOUT_FILENO);
    close(out[0]);
    close(out[1]);
    unsetenv("RAGDOLL_BLAS_CHOSEN");
    unsetenv("RAGDOLL_BLAS_REPLACED");
    if (core_type.empty()) {
      unsetenv("OPENBLAS_CORETYPE");
      setenv("RAGDOLL_BLAS_KERNELS", "library", 1);
    } else {
      setenv("OPENBLAS_CORETYPE", core_type.c_str(), 1);
    }
    char self[] = "ragdoll", doctor[] = "doctor", sgemm[] = "--sgemm";
    char* argv[] = {self, doctor, sgemm, nullptr};
    execv("/proc/self/exe", argv);
    _exit(127);
  }
  close(out[1]);
  std::string text;
  char buffer[256];
  for (ssize_t n; (n = read(out[0], buffer, sizeof buffer)) > 0;) text.append(buffer, n);
  close(out[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  char kernel[64] = {};
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0 &&
      std::sscanf(text.c_str(), "%63s %lf", kernel, &figure.gflops) == 2) {
    figure.kernel = kernel;
  }
  return figure;
}

std::string Features(const blas::Cpu& cpu) {
  if (cpu.avx512) return "AVX-512";
  if (cpu.avx2_fma) return "AVX2+FMA";
  if (cpu.avx) return "AVX";
  return "SSE only";
}

// `ragdoll train CONFIG` in a temporary folder for `seconds`, stopped with SIGINT: its samples
// per second from its first update's row of metrics.csv to its last (start-up left out).
double TrainFor(const std::string& config, int seconds) {
  char pattern[] = "/tmp/ragdoll-doctor.XXXXXX";
  if (!mkdtemp(pattern)) throw std::runtime_error("cannot make a temporary folder");
  const std::filesystem::path dir = pattern;
  const std::string port = std::to_string(43000 + 50 * (getpid() % 40));
  const std::string log = (dir / "train.log").string();
  std::vector<std::string> args = {"ragdoll",    "train",      config,        "--run-id", "doctor",
                                   "--runs-dir", dir.string(), "--port-base", port};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      dup2(fd, STDOUT_FILENO);
      dup2(fd, STDERR_FILENO);
    }
    execv("/proc/self/exe", argv.data());
    _exit(127);
  }
  std::printf("training %s for %d s (log: %s) ...\n", config.c_str(), seconds, log.c_str());
  std::fflush(stdout);
  int status = 0;
  bool exited = false;
  for (int waited = 0; waited < seconds && !exited; ++waited) {
    sleep(1);
    exited = waitpid(pid, &status, WNOHANG) == pid;
  }
  if (!exited) {
    kill(pid, SIGINT);
    for (int waited = 0; waited < 60 && !exited; ++waited) {
      sleep(1);
      exited = waitpid(pid, &status, WNOHANG) == pid;
    }
    if (!exited) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
    }
  }
  std::ifstream csv(dir / "doctor" / "metrics.csv");
  std::string line;
  std::getline(csv, line);
  std::vector<std::string> header;
  for (std::stringstream cells(line); std::getline(cells, line, ',');) header.push_back(line);
  const auto column = [&](const char* name) {
    return std::find(header.begin(), header.end(), name) - header.begin();
  };
  const size_t samples_at = column("samples"), elapsed_at = column("elapsed_s");
  std::vector<std::pair<double, double>> rows;  // elapsed, samples
  while (std::getline(csv, line)) {
    std::vector<std::string> cells;
    for (std::stringstream in(line); std::getline(in, line, ',');) cells.push_back(line);
    if (cells.size() > std::max(samples_at, elapsed_at)) {
      rows.emplace_back(std::stod(cells[elapsed_at]), std::stod(cells[samples_at]));
    }
  }
  if (rows.size() < 3) {
    throw std::runtime_error("the training made fewer than 3 updates in " +
                             std::to_string(seconds) + " s; its log: " + log);
  }
  std::filesystem::remove_all(dir);
  return (rows.back().second - rows.front().second) / (rows.back().first - rows.front().first);
}

int RunDoctor(const std::string& config, bool quick, int train_seconds,
              const std::string& json_path) {
  const blas::Cpu cpu = blas::DetectCpu();
  const blas::Library library = blas::LoadedLibrary();
  const blas::Environment env = blas::ReadEnvironment();
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  nlohmann::json out;
  std::printf("machine: %s (%s, family %d model %d): %s, %u cores\n", cpu.model_name.c_str(),
              cpu.vendor.c_str(), cpu.family, cpu.model, Features(cpu).c_str(), cores);
  std::printf("%s\n", blas::Summary(false).c_str());
  out["cpu"] = {{"model_name", cpu.model_name}, {"vendor", cpu.vendor},      {"family", cpu.family},
                {"model", cpu.model},           {"features", Features(cpu)}, {"cores", cores}};
  out["blas"] = {{"library", library.name},
                 {"config", library.config},
                 {"kernel", library.kernel},
                 {"reason", blas::Decide(env, library.kernel, cpu).reason}};

  // Each kernel set the CPU could run, and the library's own choice, timed alike.
  const double running_gflops = blas::SgemmGflops(1024, 512, 512, 5);
  std::vector<KernelFigure> kernels;
  if (library.openblas) {
    std::vector<std::string> asks = {""};
    if (cpu.avx) asks.push_back("Sandybridge");
    if (cpu.avx2_fma) asks.push_back("Haswell");
    if (cpu.avx512) asks.push_back("SkylakeX");
    for (const auto& ask : asks) {
      KernelFigure k = TimeKernel(ask);
      if (k.kernel.empty()) continue;
      const bool seen = std::any_of(kernels.begin(), kernels.end(),
                                    [&](const KernelFigure& o) { return o.kernel == k.kernel; });
      if (!seen) kernels.push_back(k);
    }
  }
  std::printf("sgemm 1024x512x512, one thread:\n");
  std::printf("  %-12s %6.0f GFLOP/s  <- running\n", library.kernel.c_str(), running_gflops);
  out["sgemm_gflops"] = running_gflops;
  const KernelFigure* best = nullptr;
  for (const auto& k : kernels) {
    out["kernels"].push_back(
        {{"kernel", k.kernel}, {"gflops", k.gflops}, {"library_choice", k.asked.empty()}});
    if (!best || k.gflops > best->gflops) best = &k;
    if (k.kernel == library.kernel) continue;
    std::printf("  %-12s %6.0f GFLOP/s%s\n", k.kernel.c_str(), k.gflops,
                k.asked.empty() ? "  (the library's own choice)" : "");
  }

  std::vector<std::string> advice;
  if (best && best->kernel != library.kernel && best->gflops > 1.3 * running_gflops) {
    char line[256];
    std::snprintf(line, sizeof line, "%s kernels would run sgemm %.1fx faster: %s",
                  best->kernel.c_str(), best->gflops / running_gflops,
                  env.core_type.empty() || env.core_type == env.chosen
                      ? "ragdoll did not choose them (see the BLAS line)"
                      : "unset OPENBLAS_CORETYPE, or set it to them");
    advice.push_back(line);
  }

  if (!config.empty()) {
    const Experiment e = ReadExperiment(config);
    at::set_num_threads(1);
    const int repeats = quick ? 3 : 7;
    const bench::PhysicsFigures physics =
        bench::MeasurePhysics(e.environment, quick ? 300 : 1000, repeats);
    std::printf(
        "physics (%s): raw mj_step %.0f steps/s on one core: %.0f control steps/s at %d "
        "substeps\n",
        config.c_str(), physics.steps_per_second, physics.control_bound(), physics.substeps);
    const bench::ActorFigures actor =
        bench::MeasureActor(e, e.actor.environments, quick ? 32 : 64, repeats);
    const double actor_share = actor.with_policy / physics.control_bound();
    std::printf(
        "actor: %d environments with the policy, %.0f samples/s: %.2f of that bound "
        "(the policy costs %.0f %% on top of the environments)\n",
        e.actor.environments, actor.with_policy, actor_share, 100 * (1 / actor.ratio - 1));
    const bench::LearnerFigures learner = bench::MeasureLearner(e, quick ? 2 : 5);
    const int epochs = e.trainer.num_epoch;
    const double absorbed = learner.update / epochs;  // buffer samples per second
    std::printf(
        "learner: PPO update %.0f samples/s per epoch, %.2f of raw libtorch "
        "forward+backward+Adam (%.0f); %d epochs: %.0f new samples/s; its products %.0f "
        "GFLOP/s, %.2f of sgemm\n",
        learner.update, learner.ratio, learner.raw, epochs, absorbed, learner.gflops,
        learner.gflops / running_gflops);
    // A sample costs 1/actor seconds of an actor's core and epochs/update of the learner's; on
    // `cores` cores shared by both, no training of this config trains faster than this.
    const double bound = cores / (1 / actor.with_policy + 1 / absorbed);
    // What `ragdoll train` runs by default: the learner on one core, an actor process on each
    // of the others; the slower side sets the pace.
    const double separate = std::min(absorbed, (cores - 1) * actor.with_policy);
    std::printf(
        "bound on %u cores: %.0f samples/s with the learner on one core and an actor on each "
        "other (what `ragdoll train` runs); %.0f if the two shared the cores perfectly (the "
        "actor's and the learner's core-seconds per sample)\n",
        cores, separate, bound);
    out["bound_separate_cores"] = separate;
    if (bound > 1.15 * separate && absorbed > (cores - 1) * actor.with_policy) {
      advice.push_back("the learner keeps up with " + std::to_string(cores - 1) +
                       " actor(s) using " +
                       std::to_string(static_cast<int>(
                           std::lround(100 * (cores - 1) * actor.with_policy / absorbed))) +
                       " % of its core: one more actor process (`ragdoll train --actors " +
                       std::to_string(cores) + "`) may use the rest");
    }
    if (train_seconds > 0) {
      const double trained = TrainFor(config, train_seconds);
      std::printf(
          "ragdoll train %s, %d s: %.0f samples/s after its first update: %.2f of the bound "
          "of its parts on their own cores, %.2f of the shared one\n",
          config.c_str(), train_seconds, trained, trained / separate, trained / bound);
      // The actor again after the training: on a machine whose speed drifts (virtual machines
      // do; docs/benchmarks.md) a share against one measurement says little.
      const double actor_after =
          bench::MeasureActor(e, e.actor.environments, quick ? 32 : 64, repeats).with_policy;
      const double separate_after = std::min(absorbed, (cores - 1) * actor_after);
      const double drift = actor_after / actor.with_policy;
      std::printf(
          "actor after the training: %.0f samples/s (%.2f of before): the training ran %.2f of "
          "the bound measured after it\n",
          actor_after, drift, trained / separate_after);
      if (drift < 0.9 || drift > 1.1) {
        advice.push_back(
            "this machine's speed changed by " +
            std::to_string(static_cast<int>(std::lround(100 * std::abs(drift - 1)))) +
            " % while measuring: the training's share lies between the two bounds' (run the "
            "doctor again on a quieter machine)");
      }
      out["train_samples_per_second"] = trained;
      out["train_share_of_bound"] = trained / separate;
      out["train_share_of_bound_after"] = trained / separate_after;
      out["train_share_of_shared_bound"] = trained / bound;
      out["actor_samples_per_second_after_training"] = actor_after;
      if (trained < 0.85 * std::min(separate, separate_after)) {
        advice.push_back(
            "the training reaches less than 0.85 of what its parts do alone: the transport, "
            "the policy lag or the episodes' resets take the rest (`ragdoll train` prints the "
            "learner's idle share; docs/monitoring.md lists the series)");
      }
    }
    out["config"] = config;
    out["physics"] = {{"steps_per_second", physics.steps_per_second},
                      {"substeps", physics.substeps},
                      {"control_bound", physics.control_bound()}};
    out["actor"] = {{"environments", e.actor.environments},
                    {"samples_per_second", actor.with_policy},
                    {"share_of_physics_bound", actor_share},
                    {"ratio_to_environments_alone", actor.ratio}};
    out["learner"] = {{"update_samples_per_second_per_epoch", learner.update},
                      {"raw_samples_per_second", learner.raw},
                      {"ratio_to_raw", learner.ratio},
                      {"gflops", learner.gflops},
                      {"share_of_sgemm", learner.gflops / running_gflops},
                      {"epochs", epochs}};
    out["bound_samples_per_second"] = bound;
    if (learner.ratio < 0.8) {
      advice.push_back(
          "the PPO update runs below 0.8 of raw libtorch: something beside the "
          "gradient steps is slow");
    }
    if (actor.ratio < 0.8) {
      advice.push_back(
          "the policy costs the actor more than a quarter of its time: a smaller "
          "network or more environments per actor batch it better");
    }
  }
  std::printf("would change: %s\n", advice.empty() ? "nothing" : "");
  for (const auto& line : advice) std::printf("  - %s\n", line.c_str());
  out["advice"] = advice;
  if (!json_path.empty()) {
    std::ofstream file(json_path);
    file << out.dump(2) << "\n";
    if (!file) {
      std::fprintf(stderr, "ragdoll doctor: cannot write %s\n", json_path.c_str());
      return 1;
    }
  }
  return 0;
}

}  // namespace

std::function<int()> AddDoctorCommand(CLI::App& app) {
  struct Options {
    std::string config = "configs/walk.yaml", json;
    int train = 0;
    bool quick = false, blas_only = false, sgemm = false;
  };
  auto o = std::make_shared<Options>();
  auto* cmd = app.add_subcommand(
      "doctor",
      "this machine's limits (mj_step, sgemm per BLAS kernel set) and the actor's and "
      "learner's ratios to them");
  cmd->add_option("config", o->config, "experiment YAML whose actor and learner are measured")
      ->capture_default_str();
  cmd->add_flag("--quick", o->quick, "fewer repeats (a few seconds)");
  cmd->add_flag("--blas-only", o->blas_only, "the CPU and the BLAS kernels only");
  cmd->add_option("--json", o->json, "also write the figures to this file");
  cmd->add_option("--train", o->train,
                  "also run `ragdoll train CONFIG` this many seconds and set its samples/s "
                  "against the bound")
      ->check(CLI::Range(0, 36000));
  cmd->add_flag("--sgemm", o->sgemm)->group("");  // a child timing one kernel set
  return [cmd, o]() -> int {
    if (!*cmd) return -1;
    if (o->sgemm) {
      std::printf("%s %.2f\n", blas::LoadedLibrary().kernel.c_str(), blas::SgemmGflops());
      return 0;
    }
    return RunDoctor(o->blas_only ? "" : o->config, o->quick, o->train, o->json);
  };
}

}  // namespace ragdoll::cli
