// Which BLAS kernels this process runs, what the CPU could run, and the choice between them.
// OpenBLAS picks its kernel set when it loads, from the CPU's model; a model it does not know
// gets an SSE3-era fallback (docs/benchmarks.md). Every `ragdoll` process asks for the set its
// CPU supports before anything else runs, by setting OPENBLAS_CORETYPE and executing itself
// again; an OPENBLAS_CORETYPE the user set is always kept.
#pragma once

#include <string>

namespace ragdoll::blas {

struct Cpu {
  std::string model_name;  // as /proc/cpuinfo and cpuid's brand string give it
  std::string vendor;
  int family = 0;
  int model = 0;
  bool avx = false;  // with the OS saving the YMM state
  bool avx2_fma = false;
  bool avx512 = false;  // F, CD, BW, DQ and VL, with the OS saving the ZMM state
};

Cpu DetectCpu();

// The BLAS libtorch calls, as loaded in this process.
struct Library {
  std::string name;    // "OpenBLAS 0.3.21", or "a BLAS without OpenBLAS's queries"
  std::string config;  // OpenBLAS's build configuration, as it gives it
  std::string kernel;  // OpenBLAS's core name ("Prescott", "Haswell", "SkylakeX"); empty if unknown
  bool openblas = false;
};

Library LoadedLibrary();

// The OpenBLAS kernel set for a CPU: SkylakeX with AVX-512, Haswell with AVX2 and FMA,
// Sandybridge with AVX; empty when the CPU has none of these.
std::string KernelFor(const Cpu& cpu);

// Instruction-set rank of an OpenBLAS core name: 3 AVX-512, 2 AVX2, 1 AVX, 0 SSE; -1 unknown.
int KernelRank(const std::string& kernel);

// What the process environment says about OPENBLAS_CORETYPE.
struct Environment {
  std::string core_type;  // OPENBLAS_CORETYPE
  std::string chosen;     // RAGDOLL_BLAS_CHOSEN: OPENBLAS_CORETYPE was set by ragdoll, to this
  std::string replaced;   // RAGDOLL_BLAS_REPLACED: the library's own choice ragdoll replaced
  std::string rejected;   // RAGDOLL_BLAS_REJECTED: a choice that failed the numerical check
  bool library_choice = false;  // RAGDOLL_BLAS_KERNELS=library: leave OpenBLAS's own choice
};

Environment ReadEnvironment();

struct Decision {
  std::string switch_to;  // a kernel set to ask for; empty: keep what runs
  std::string reason;     // one line for the log
};

// Pure: keep the running kernel or switch. A user's OPENBLAS_CORETYPE is kept; a choice that
// failed its check or that the library ignored is not asked for again.
Decision Decide(const Environment& env, const std::string& running, const Cpu& cpu);

struct Check {
  double max_error = 0;  // sgemm against a double-precision product, largest absolute difference
  bool ok = false;
};

// A 97x83x61 sgemm of values in [-1, 1] against the same product in double precision.
Check SelfCheck();

// One-thread sgemm GFLOP/s on m x k times k x n (best of `repeats`); 0 without a cblas_sgemm.
double SgemmGflops(int m = 1024, int n = 512, int k = 512, int repeats = 3);

// At the start of main(), before any thread: may replace the process image (execv) with
// OPENBLAS_CORETYPE set to the CPU's kernel set, or, when that set fails the self-check, with the
// library's own choice again. What it did is in Summary().
void ChooseKernels(char** argv);

// "BLAS: OpenBLAS 0.3.21 ..., SkylakeX kernels (chosen by ragdoll; the library chose Prescott on
// this AVX-512 CPU)": for each role's start-up log. With `measure`, adds the sgemm figure.
std::string Summary(bool measure);

}  // namespace ragdoll::blas
