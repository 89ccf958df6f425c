#include "cli/doctor_command.h"

#include <signal.h>
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

#include "bench/measure.h"
#include "common/blas.h"
#include "common/process.h"
#include "run/experiment.h"

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
  ChildProcess::Options options;
  options.program = kThisProgram;
  options.output = ChildProcess::Output::kPipe;
  options.environment = {{"RAGDOLL_BLAS_CHOSEN", std::nullopt},
                         {"RAGDOLL_BLAS_REPLACED", std::nullopt}};
  if (core_type.empty()) {
    options.environment["OPENBLAS_CORETYPE"] = std::nullopt;
    options.environment["RAGDOLL_BLAS_KERNELS"] = "library";
  } else {
    options.environment["OPENBLAS_CORETYPE"] = core_type;
  }
  std::string text;
  int code = -1;
  try {
    ChildProcess child({"ragdoll", "doctor", "--sgemm"}, options);
    text = child.ReadOutput();
    code = child.Wait();
  } catch (const std::runtime_error&) {
    return figure;  // no process for it: no figure, as for a child that failed
  }
  char kernel[64] = {};
  if (code == 0 && std::sscanf(text.c_str(), "%63s %lf", kernel, &figure.gflops) == 2) {
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
  ChildProcess::Options options;
  options.program = kThisProgram;
  options.output = ChildProcess::Output::kLog;
  options.log = log;
  ChildProcess train({"ragdoll", "train", config, "--run-id", "doctor", "--runs-dir", dir.string(),
                      "--port-base", port},
                     options);
  std::printf("training %s for %d s (log: %s) ...\n", config.c_str(), seconds, log.c_str());
  std::fflush(stdout);
  bool exited = false;
  for (int waited = 0; waited < seconds && !exited; ++waited) {
    sleep(1);
    exited = !train.Running();
  }
  // As Ctrl-C would: the training stops its roles and saves; a minute for that.
  if (!exited) train.Terminate(60, SIGINT);
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

// What the doctor finds: printed as it goes, gathered for --json, and its advice at the end.
struct Findings {
  nlohmann::json out;
  std::vector<std::string> advice;
};

// The machine and the BLAS it runs.
void DescribeMachine(const blas::Cpu& cpu, const blas::Library& library,
                     const blas::Environment& env, unsigned cores, Findings& found) {
  std::printf("machine: %s (%s, family %d model %d): %s, %u cores\n", cpu.model_name.c_str(),
              cpu.vendor.c_str(), cpu.family, cpu.model, Features(cpu).c_str(), cores);
  std::printf("%s\n", blas::Summary(false).c_str());
  found.out["cpu"] = {{"model_name", cpu.model_name}, {"vendor", cpu.vendor},
                      {"family", cpu.family},         {"model", cpu.model},
                      {"features", Features(cpu)},    {"cores", cores}};
  found.out["blas"] = {{"library", library.name},
                       {"config", library.config},
                       {"kernel", library.kernel},
                       {"reason", blas::Decide(env, library.kernel, cpu).reason}};
}

// Each kernel set the CPU could run, and the library's own choice, timed alike: one figure per
// kernel set the children ran (the library's own choice is often one of the others).
std::vector<KernelFigure> TimeKernels(const blas::Cpu& cpu, const blas::Library& library) {
  std::vector<KernelFigure> kernels;
  if (!library.openblas) return kernels;
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
  return kernels;
}

// The kernel sets' sgemm against the running one's; advice when another is much faster.
void CompareKernels(const std::vector<KernelFigure>& kernels, const blas::Library& library,
                    const blas::Environment& env, double running_gflops, Findings& found) {
  std::printf("sgemm 1024x512x512, one thread:\n");
  std::printf("  %-12s %6.0f GFLOP/s  <- running\n", library.kernel.c_str(), running_gflops);
  found.out["sgemm_gflops"] = running_gflops;
  const KernelFigure* best = nullptr;
  for (const auto& k : kernels) {
    found.out["kernels"].push_back(
        {{"kernel", k.kernel}, {"gflops", k.gflops}, {"library_choice", k.asked.empty()}});
    if (!best || k.gflops > best->gflops) best = &k;
    if (k.kernel == library.kernel) continue;
    std::printf("  %-12s %6.0f GFLOP/s%s\n", k.kernel.c_str(), k.gflops,
                k.asked.empty() ? "  (the library's own choice)" : "");
  }
  if (best && best->kernel != library.kernel && best->gflops > 1.3 * running_gflops) {
    char line[256];
    std::snprintf(line, sizeof line, "%s kernels would run sgemm %.1fx faster: %s",
                  best->kernel.c_str(), best->gflops / running_gflops,
                  env.core_type.empty() || env.core_type == env.chosen
                      ? "ragdoll did not choose them (see the BLAS line)"
                      : "unset OPENBLAS_CORETYPE, or set it to them");
    found.advice.push_back(line);
  }
}

// One config's parts, each measured alone, and what they bound a training to.
struct Parts {
  bench::PhysicsFigures physics;
  bench::ActorFigures actor;
  bench::LearnerFigures learner;
  int epochs = 0;
  double absorbed = 0;  // buffer samples per second
  double bound = 0;     // on cores shared by both
  double separate = 0;  // the learner on one core, an actor on each other
  double actor_share() const { return actor.with_policy / physics.control_bound(); }
};

// Physics, actor and learner of `e`, each measured alone and printed.
Parts MeasureParts(const std::string& config, const run::Experiment& e, bool quick,
                   double running_gflops) {
  Parts p;
  const int repeats = quick ? 3 : 7;
  p.physics = bench::MeasurePhysics(e.environment, quick ? 300 : 1000, repeats);
  std::printf(
      "physics (%s): raw mj_step %.0f steps/s on one core: %.0f control steps/s at %d "
      "substeps\n",
      config.c_str(), p.physics.steps_per_second, p.physics.control_bound(), p.physics.substeps);
  p.actor = bench::MeasureActor(e, e.actor.environments, quick ? 32 : 64, repeats);
  std::printf(
      "actor: %d environments with the policy, %.0f samples/s: %.2f of that bound "
      "(the policy costs %.0f %% on top of the environments)\n",
      e.actor.environments, p.actor.with_policy, p.actor_share(), 100 * (1 / p.actor.ratio - 1));
  p.learner = bench::MeasureLearner(e, quick ? 2 : 5);
  p.epochs = e.trainer.num_epoch;
  p.absorbed = p.learner.update / p.epochs;
  std::printf(
      "learner: PPO update %.0f samples/s per epoch, %.2f of raw libtorch "
      "forward+backward+Adam (%.0f); %d epochs: %.0f new samples/s; its products %.0f "
      "GFLOP/s, %.2f of sgemm\n",
      p.learner.update, p.learner.ratio, p.learner.raw, p.epochs, p.absorbed, p.learner.gflops,
      p.learner.gflops / running_gflops);
  return p;
}

// The two bounds on `cores` cores, printed; advice when the learner has a core's room to spare.
void Bound(Parts& p, unsigned cores, Findings& found) {
  // A sample costs 1/actor seconds of an actor's core and epochs/update of the learner's; on
  // `cores` cores shared by both, no training of this config trains faster than this.
  p.bound = cores / (1 / p.actor.with_policy + 1 / p.absorbed);
  // What `ragdoll train` runs by default: the learner on one core, an actor process on each
  // of the others; the slower side sets the pace.
  p.separate = std::min(p.absorbed, (cores - 1) * p.actor.with_policy);
  std::printf(
      "bound on %u cores: %.0f samples/s with the learner on one core and an actor on each "
      "other (what `ragdoll train` runs); %.0f if the two shared the cores perfectly (the "
      "actor's and the learner's core-seconds per sample)\n",
      cores, p.separate, p.bound);
  found.out["bound_separate_cores"] = p.separate;
  if (p.bound > 1.15 * p.separate && p.absorbed > (cores - 1) * p.actor.with_policy) {
    found.advice.push_back("the learner keeps up with " + std::to_string(cores - 1) +
                           " actor(s) using " +
                           std::to_string(static_cast<int>(
                               std::lround(100 * (cores - 1) * p.actor.with_policy / p.absorbed))) +
                           " % of its core: one more actor process (`ragdoll train --actors " +
                           std::to_string(cores) + "`) may use the rest");
  }
}

// `ragdoll train` for `seconds` against the bounds, and the actor measured again after it.
void MeasureTraining(const std::string& config, const run::Experiment& e, int seconds, bool quick,
                     unsigned cores, const Parts& p, Findings& found) {
  const double trained = TrainFor(config, seconds);
  std::printf(
      "ragdoll train %s, %d s: %.0f samples/s after its first update: %.2f of the bound "
      "of its parts on their own cores, %.2f of the shared one\n",
      config.c_str(), seconds, trained, trained / p.separate, trained / p.bound);
  // The actor again after the training: on a machine whose speed drifts (virtual machines
  // do; docs/benchmarks.md) a share against one measurement says little.
  const double actor_after =
      bench::MeasureActor(e, e.actor.environments, quick ? 32 : 64, quick ? 3 : 7).with_policy;
  const double separate_after = std::min(p.absorbed, (cores - 1) * actor_after);
  const double drift = actor_after / p.actor.with_policy;
  std::printf(
      "actor after the training: %.0f samples/s (%.2f of before): the training ran %.2f of "
      "the bound measured after it\n",
      actor_after, drift, trained / separate_after);
  if (drift < 0.9 || drift > 1.1) {
    found.advice.push_back(
        "this machine's speed changed by " +
        std::to_string(static_cast<int>(std::lround(100 * std::abs(drift - 1)))) +
        " % while measuring: the training's share lies between the two bounds' (run the "
        "doctor again on a quieter machine)");
  }
  found.out["train_samples_per_second"] = trained;
  found.out["train_share_of_bound"] = trained / p.separate;
  found.out["train_share_of_bound_after"] = trained / separate_after;
  found.out["train_share_of_shared_bound"] = trained / p.bound;
  found.out["actor_samples_per_second_after_training"] = actor_after;
  if (trained < 0.85 * std::min(p.separate, separate_after)) {
    found.advice.push_back(
        "the training reaches less than 0.85 of what its parts do alone: the transport, "
        "the policy lag or the episodes' resets take the rest (`ragdoll train` prints the "
        "learner's idle share; docs/monitoring.md lists the series)");
  }
}

// The parts' figures for --json; advice when either part spends much beside its real work.
void RecordParts(const std::string& config, const run::Experiment& e, const Parts& p,
                 double running_gflops, Findings& found) {
  found.out["config"] = config;
  found.out["physics"] = {{"steps_per_second", p.physics.steps_per_second},
                          {"substeps", p.physics.substeps},
                          {"control_bound", p.physics.control_bound()}};
  found.out["actor"] = {{"environments", e.actor.environments},
                        {"samples_per_second", p.actor.with_policy},
                        {"share_of_physics_bound", p.actor_share()},
                        {"ratio_to_environments_alone", p.actor.ratio}};
  found.out["learner"] = {{"update_samples_per_second_per_epoch", p.learner.update},
                          {"raw_samples_per_second", p.learner.raw},
                          {"ratio_to_raw", p.learner.ratio},
                          {"gflops", p.learner.gflops},
                          {"share_of_sgemm", p.learner.gflops / running_gflops},
                          {"epochs", p.epochs}};
  found.out["bound_samples_per_second"] = p.bound;
  if (p.learner.ratio < 0.8) {
    found.advice.push_back(
        "the PPO update runs below 0.8 of raw libtorch: something beside the "
        "gradient steps is slow");
  }
  if (p.actor.ratio < 0.8) {
    found.advice.push_back(
        "the policy costs the actor more than a quarter of its time: a smaller "
        "network or more environments per actor batch it better");
  }
}

// A config's actor and learner against the machine's limits, and with --train the real thing.
void MeasureConfig(const std::string& config, bool quick, int train_seconds, unsigned cores,
                   double running_gflops, Findings& found) {
  const run::Experiment e = run::ReadExperiment(config);
  at::set_num_threads(1);
  Parts parts = MeasureParts(config, e, quick, running_gflops);
  Bound(parts, cores, found);
  if (train_seconds > 0) MeasureTraining(config, e, train_seconds, quick, cores, parts, found);
  RecordParts(config, e, parts, running_gflops, found);
}

// The advice, and the figures into `json_path` when given; the command's exit code.
int Conclude(Findings& found, const std::string& json_path) {
  std::printf("would change: %s\n", found.advice.empty() ? "nothing" : "");
  for (const auto& line : found.advice) std::printf("  - %s\n", line.c_str());
  found.out["advice"] = found.advice;
  if (!json_path.empty()) {
    std::ofstream file(json_path);
    file << found.out.dump(2) << "\n";
    if (!file) {
      std::fprintf(stderr, "ragdoll doctor: cannot write %s\n", json_path.c_str());
      return 1;
    }
  }
  return 0;
}

int RunDoctor(const std::string& config, bool quick, int train_seconds,
              const std::string& json_path) {
  const blas::Cpu cpu = blas::DetectCpu();
  const blas::Library library = blas::LoadedLibrary();
  const blas::Environment env = blas::ReadEnvironment();
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  Findings found;
  DescribeMachine(cpu, library, env, cores, found);
  const double running_gflops = blas::SgemmGflops(1024, 512, 512, 5);
  CompareKernels(TimeKernels(cpu, library), library, env, running_gflops, found);
  if (!config.empty()) MeasureConfig(config, quick, train_seconds, cores, running_gflops, found);
  return Conclude(found, json_path);
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
