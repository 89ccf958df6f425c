#include "common/blas.h"

#include <gtest/gtest.h>

#include <cstdlib>

namespace ragdoll::blas {
namespace {

Cpu Avx512Cpu() {
  Cpu cpu;
  cpu.avx = cpu.avx2_fma = cpu.avx512 = true;
  return cpu;
}

TEST(Blas, KernelsAreRankedByTheirWidestVectors) {
  EXPECT_EQ(KernelRank("Prescott"), 0);
  EXPECT_EQ(KernelRank("Sandybridge"), 1);
  EXPECT_EQ(KernelRank("Haswell"), 2);
  EXPECT_EQ(KernelRank("Zen"), 2);
  EXPECT_EQ(KernelRank("SkylakeX"), 3);
  EXPECT_EQ(KernelRank("skylakex"), 3);  // OPENBLAS_CORETYPE is read without case
  EXPECT_EQ(KernelRank("Loongson3R4"), -1);
  EXPECT_EQ(KernelRank(""), -1);
}

TEST(Blas, TheCpuGetsItsWidestKernelSet) {
  Cpu cpu;
  EXPECT_EQ(KernelFor(cpu), "");
  cpu.avx = true;
  EXPECT_EQ(KernelFor(cpu), "Sandybridge");
  cpu.avx2_fma = true;
  EXPECT_EQ(KernelFor(cpu), "Haswell");
  cpu.avx512 = true;
  EXPECT_EQ(KernelFor(cpu), "SkylakeX");
}

TEST(Blas, AFallbackKernelIsReplacedByTheCpusOwn) {
  const Decision d = Decide({}, "Prescott", Avx512Cpu());
  EXPECT_EQ(d.switch_to, "SkylakeX");
  EXPECT_NE(d.reason.find("Prescott"), std::string::npos) << d.reason;
  Cpu avx2 = Avx512Cpu();
  avx2.avx512 = false;
  EXPECT_EQ(Decide({}, "Prescott", avx2).switch_to, "Haswell");
  EXPECT_EQ(Decide({}, "Sandybridge", avx2).switch_to, "Haswell");
}

TEST(Blas, AKernelThatFitsIsKept) {
  Cpu avx2 = Avx512Cpu();
  avx2.avx512 = false;
  EXPECT_EQ(Decide({}, "Haswell", avx2).switch_to, "");
  EXPECT_EQ(Decide({}, "Zen", avx2).switch_to, "");
  EXPECT_EQ(Decide({}, "SkylakeX", Avx512Cpu()).switch_to, "");
  EXPECT_EQ(Decide({}, "Prescott", Cpu{}).switch_to, "");           // no AVX: nothing better
  EXPECT_EQ(Decide({}, "Loongson3R4", Avx512Cpu()).switch_to, "");  // not ranked: left alone
}

TEST(Blas, TheUsersSettingAlwaysWins) {
  Environment env;
  env.core_type = "Prescott";
  const Decision d = Decide(env, "Prescott", Avx512Cpu());
  EXPECT_EQ(d.switch_to, "");
  EXPECT_NE(d.reason.find("OPENBLAS_CORETYPE=Prescott set in the environment: kept"),
            std::string::npos)
      << d.reason;
  EXPECT_NE(d.reason.find("SkylakeX"), std::string::npos) << "says what the CPU could run";
  env.library_choice = true;
  env.core_type.clear();
  EXPECT_EQ(Decide(env, "Prescott", Avx512Cpu()).switch_to, "");
}

TEST(Blas, RagdollsOwnChoiceIsReconsideredButNeverLoops) {
  Environment env;
  env.core_type = env.chosen = "Prescott";  // set by a parent ragdoll, not the user
  EXPECT_EQ(Decide(env, "Prescott", Avx512Cpu()).switch_to, "SkylakeX");
  env.core_type = env.chosen = "SkylakeX";
  env.replaced = "Prescott";
  const Decision kept = Decide(env, "SkylakeX", Avx512Cpu());
  EXPECT_EQ(kept.switch_to, "");
  EXPECT_NE(kept.reason.find("chosen by ragdoll; the library chose Prescott"), std::string::npos)
      << kept.reason;
  // Asked for, but the library ignored the variable: do not ask again.
  EXPECT_EQ(Decide(env, "Prescott", Avx512Cpu()).switch_to, "");
  // Failed its numerical check: the library's own choice stays.
  Environment rejected;
  rejected.rejected = "SkylakeX";
  EXPECT_EQ(Decide(rejected, "Prescott", Avx512Cpu()).switch_to, "");
}

// The library this test runs on (tests/CMakeLists.txt sets OPENBLAS_CORETYPE for the recorded
// digests): it is what it says it is, and its products are right.
TEST(Blas, TheLoadedLibraryAnswersAndComputesRight) {
  const Library library = LoadedLibrary();
  ASSERT_FALSE(library.name.empty());
  const char* asked = std::getenv("OPENBLAS_CORETYPE");
  if (library.openblas && asked) {
    EXPECT_EQ(library.kernel, asked);
  }
  const Check check = SelfCheck();
  EXPECT_TRUE(check.ok);
  EXPECT_LT(check.max_error, 1e-4);
  EXPECT_GT(SgemmGflops(128, 128, 128, 1), 0.1);
}

}  // namespace
}  // namespace ragdoll::blas
