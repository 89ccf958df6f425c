#include "common/blas.h"

#include <dlfcn.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>
#include <vector>

#if defined(__x86_64__) || defined(__i386__)
#include <cpuid.h>
#endif

namespace ragdoll::blas {
namespace {

constexpr const char* kCoreType = "OPENBLAS_CORETYPE";
constexpr const char* kChosen = "RAGDOLL_BLAS_CHOSEN";
constexpr const char* kReplaced = "RAGDOLL_BLAS_REPLACED";
constexpr const char* kRejected = "RAGDOLL_BLAS_REJECTED";
constexpr const char* kKernels = "RAGDOLL_BLAS_KERNELS";
constexpr double kCheckTolerance = 1e-4;  // float sums of 61 products in [-1, 1] err ~1e-6

std::string Getenv(const char* name) {
  const char* value = std::getenv(name);
  return value ? value : "";
}

template <typename F>
F Symbol(const char* name) {
  return reinterpret_cast<F>(dlsym(RTLD_DEFAULT, name));
}

// CBLAS's row-major, no-transpose sgemm (enum values from cblas.h: 101 row major, 111 no trans).
using CblasSgemm = void (*)(int, int, int, int, int, int, float, const float*, int, const float*,
                            int, float, float*, int);
using GetThreads = int (*)();
using SetThreads = void (*)(int);

// OpenBLAS's thread count at 1 while a figure is taken, restored after.
class OneThread {
 public:
  OneThread()
      : get_(Symbol<GetThreads>("openblas_get_num_threads")),
        set_(Symbol<SetThreads>("openblas_set_num_threads")) {
    if (get_ && set_) {
      saved_ = get_();
      set_(1);
    }
  }
  ~OneThread() {
    if (get_ && set_) set_(saved_);
  }
  OneThread(const OneThread&) = delete;
  OneThread& operator=(const OneThread&) = delete;

 private:
  GetThreads get_;
  SetThreads set_;
  int saved_ = 1;
};

std::string Trim(std::string s) {
  s.erase(0, s.find_first_not_of(" \t"));
  s.erase(s.find_last_not_of(" \t\n") + 1);
  return s;
}

const char* RankName(int rank) {
  static const char* names[] = {"SSE", "AVX", "AVX2", "AVX-512"};
  return rank >= 0 && rank <= 3 ? names[rank] : "unknown";
}

}  // namespace

Cpu DetectCpu() {
  Cpu cpu;
#if defined(__x86_64__) || defined(__i386__)
  unsigned a = 0, b = 0, c = 0, d = 0;
  if (__get_cpuid(0, &a, &b, &c, &d)) {
    char vendor[13] = {};
    std::memcpy(vendor, &b, 4);
    std::memcpy(vendor + 4, &d, 4);
    std::memcpy(vendor + 8, &c, 4);
    cpu.vendor = vendor;
  }
  const unsigned max_leaf = a;
  bool ymm = false, zmm = false;
  if (__get_cpuid(1, &a, &b, &c, &d)) {
    const unsigned base_family = (a >> 8) & 0xf;
    cpu.family =
        static_cast<int>(base_family == 0xf ? base_family + ((a >> 20) & 0xff) : base_family);
    cpu.model = static_cast<int>(
        ((a >> 4) & 0xf) | ((base_family == 6 || base_family == 0xf) ? ((a >> 12) & 0xf0) : 0));
    const bool osxsave = c & (1u << 27);
    if (osxsave) {
      unsigned lo = 0, hi = 0;
      __asm__("xgetbv" : "=a"(lo), "=d"(hi) : "c"(0));
      ymm = (lo & 0x6) == 0x6;    // SSE and AVX state
      zmm = (lo & 0xe6) == 0xe6;  // and opmask, upper ZMM, high ZMM
    }
    cpu.avx = ymm && (c & (1u << 28));
    const bool fma = c & (1u << 12);
    if (max_leaf >= 7 && __get_cpuid_count(7, 0, &a, &b, &c, &d)) {
      cpu.avx2_fma = cpu.avx && fma && (b & (1u << 5));
      const unsigned avx512 = (1u << 16) | (1u << 17) | (1u << 28) | (1u << 30) | (1u << 31);
      cpu.avx512 = cpu.avx2_fma && zmm && (b & avx512) == avx512;
    }
  }
#endif
  std::ifstream cpuinfo("/proc/cpuinfo");
  for (std::string line; std::getline(cpuinfo, line);) {
    if (line.rfind("model name", 0) == 0) {
      cpu.model_name = Trim(line.substr(line.find(':') + 1));
      break;
    }
  }
  return cpu;
}

Library LoadedLibrary() {
  Library library;
  using GetString = char* (*)();
  auto config = Symbol<GetString>("openblas_get_config");
  auto corename = Symbol<GetString>("openblas_get_corename");
  if (config && corename) {
    library.openblas = true;
    // "OpenBLAS 0.3.21 NO_LAPACKE DYNAMIC_ARCH ... SkylakeX MAX_THREADS=64": the name and version,
    // then build options (the target named there is the build's, not what runs: the core name).
    library.config = Trim(config());
    std::istringstream words(library.config);
    std::string product, version;
    words >> product >> version;
    library.name = product + " " + version;
    library.kernel = Trim(corename());
  } else if (Symbol<CblasSgemm>("cblas_sgemm")) {
    library.name = "a BLAS without OpenBLAS's queries (the reference BLAS?)";
  } else {
    library.name = "no BLAS loaded";
  }
  return library;
}

std::string KernelFor(const Cpu& cpu) {
  if (cpu.avx512) return "SkylakeX";
  if (cpu.avx2_fma) return "Haswell";
  if (cpu.avx) return "Sandybridge";
  return "";
}

int KernelRank(const std::string& kernel) {
  // OpenBLAS 0.3's x86-64 core names by the widest vector set their kernels use.
  static const std::pair<const char*, int> ranks[] = {
      {"SkylakeX", 3},   {"Cooperlake", 3},    {"SapphireRapids", 3}, {"Haswell", 2},
      {"Zen", 2},        {"Excavator", 2},     {"Sandybridge", 1},    {"Bulldozer", 1},
      {"Piledriver", 1}, {"Steamroller", 1},   {"Prescott", 0},       {"Core2", 0},
      {"Penryn", 0},     {"Dunnington", 0},    {"Nehalem", 0},        {"Atom", 0},
      {"Opteron", 0},    {"Opteron(SSE3)", 0}, {"Barcelona", 0},      {"Bobcat", 0},
      {"Katmai", 0},     {"Coppermine", 0},    {"Northwood", 0},      {"Banias", 0},
      {"Nano", 0}};
  for (const auto& [name, rank] : ranks) {
    if (strcasecmp(name, kernel.c_str()) == 0) return rank;
  }
  return -1;
}

Environment ReadEnvironment() {
  return {Getenv(kCoreType), Getenv(kChosen), Getenv(kReplaced), Getenv(kRejected),
          Getenv(kKernels) == "library"};
}

Decision Decide(const Environment& env, const std::string& running, const Cpu& cpu) {
  const bool users = !env.core_type.empty() && env.core_type != env.chosen;
  const std::string target = KernelFor(cpu);
  const int have = KernelRank(running), want = KernelRank(target);
  if (users) {
    std::string reason = "OPENBLAS_CORETYPE=" + env.core_type + " set in the environment: kept";
    if (have >= 0 && want > have) {
      reason += " (this " + std::string(RankName(want)) + " CPU runs " + target +
                " kernels; `ragdoll doctor` compares them)";
    }
    return {"", reason};
  }
  if (env.library_choice) return {"", "RAGDOLL_BLAS_KERNELS=library: the library's own choice"};
  if (target.empty()) return {"", "no AVX on this CPU: the library's own choice"};
  if (have < 0) return {"", "a kernel set ragdoll does not rank: the library's own choice"};
  if (have >= want) {
    return {"", env.chosen.empty() ? "the library's own choice, which fits this CPU"
                                   : "chosen by ragdoll; the library chose " +
                                         (env.replaced.empty() ? "it" : env.replaced) +
                                         " on this " + RankName(want) + " CPU"};
  }
  if (!env.rejected.empty() && strcasecmp(env.rejected.c_str(), target.c_str()) == 0) {
    return {"", target + " kernels failed the numerical check: the library's own choice"};
  }
  if (env.chosen == target) {
    return {"", "ragdoll asked for " + target + " kernels, the library runs " + running +
                    " (OPENBLAS_CORETYPE ignored: not a DYNAMIC_ARCH build?)"};
  }
  return {target, "the library chose " + running + " on this " + RankName(want) + " CPU"};
}

Check SelfCheck() {
  Check check;
  auto sgemm = Symbol<CblasSgemm>("cblas_sgemm");
  if (!sgemm) return check;
  const int m = 97, n = 83, k = 61;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1, 1);
  std::vector<float> a(m * k), b(k * n), c(m * n, 0);
  for (float& x : a) x = u(rng);
  for (float& x : b) x = u(rng);
  {
    OneThread one;
    sgemm(101, 111, 111, m, n, k, 1.0f, a.data(), k, b.data(), n, 0.0f, c.data(), n);
  }
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j < n; ++j) {
      double sum = 0;
      for (int p = 0; p < k; ++p) sum += double(a[i * k + p]) * b[p * n + j];
      const double error = std::abs(sum - c[i * n + j]);
      check.max_error = std::isfinite(error) ? std::max(check.max_error, error) : INFINITY;
    }
  }
  check.ok = check.max_error <= kCheckTolerance;
  return check;
}

double SgemmGflops(int m, int n, int k, int repeats) {
  auto sgemm = Symbol<CblasSgemm>("cblas_sgemm");
  if (!sgemm) return 0;
  std::vector<float> a(size_t(m) * k, 0.5f), b(size_t(k) * n, 0.25f), c(size_t(m) * n);
  OneThread one;
  sgemm(101, 111, 111, m, n, k, 1.0f, a.data(), k, b.data(), n, 0.0f, c.data(), n);  // warm-up
  double best = 1e30;
  for (int r = 0; r < repeats; ++r) {
    const auto start = std::chrono::steady_clock::now();
    sgemm(101, 111, 111, m, n, k, 1.0f, a.data(), k, b.data(), n, 0.0f, c.data(), n);
    best = std::min(
        best, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  return 2.0 * m * n * k / best / 1e9;
}

void ChooseKernels(char** argv) {
  const Environment env = ReadEnvironment();
  const Library library = LoadedLibrary();
  if (!library.openblas) return;
  const Cpu cpu = DetectCpu();
  // Running a kernel set ragdoll asked for: check it before trusting it.
  if (!env.chosen.empty() && env.core_type == env.chosen &&
      strcasecmp(library.kernel.c_str(), env.chosen.c_str()) == 0) {
    const Check check = SelfCheck();
    if (!check.ok) {
      std::fprintf(stderr,
                   "ragdoll: OpenBLAS's %s kernels differ from a double-precision product by "
                   "%.3g on this CPU; going back to the library's own choice\n",
                   env.chosen.c_str(), check.max_error);
      unsetenv(kCoreType);
      unsetenv(kChosen);
      setenv(kRejected, env.chosen.c_str(), 1);
      execv("/proc/self/exe", argv);
      std::perror("ragdoll: execv /proc/self/exe");
      return;
    }
  }
  const Decision decision = Decide(env, library.kernel, cpu);
  if (decision.switch_to.empty()) return;
  setenv(kCoreType, decision.switch_to.c_str(), 1);
  setenv(kChosen, decision.switch_to.c_str(), 1);
  setenv(kReplaced, library.kernel.c_str(), 1);
  execv("/proc/self/exe", argv);
  // Still here: go on with the library's choice, which is slower, not wrong.
  std::perror("ragdoll: execv /proc/self/exe (to choose BLAS kernels)");
  unsetenv(kCoreType);
  unsetenv(kChosen);
  unsetenv(kReplaced);
}

std::string Summary(bool measure) {
  const Library library = LoadedLibrary();
  std::string line = "BLAS: " + library.name;
  if (library.openblas) {
    const Decision decision = Decide(ReadEnvironment(), library.kernel, DetectCpu());
    line += ", " + library.kernel + " kernels (" + decision.reason + ")";
  }
  if (measure) {
    char figure[64];
    std::snprintf(figure, sizeof figure, "; sgemm %.0f GFLOP/s on one thread", SgemmGflops());
    line += figure;
  }
  return line;
}

}  // namespace ragdoll::blas
