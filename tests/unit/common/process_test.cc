// Starting other programs: exit codes, output, input, groups, timeouts and programs that are not
// there, with real processes (sh, cat, sleep).
#include "common/process.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>

namespace ragdoll {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Alive and not a zombie (an orphan's zombie waits for whoever adopts it to reap it).
bool Alive(pid_t pid) {
  if (kill(pid, 0) != 0) return false;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string skip, state;
  stat >> skip >> skip >> state;
  return state != "Z";
}

TEST(ChildProcess, ReportsExitCodesAndSignals) {
  ChildProcess exits({"sh", "-c", "exit 3"}, {});
  EXPECT_EQ(exits.Wait(), 3);
  EXPECT_FALSE(exits.Running());
  ChildProcess killed({"sh", "-c", "kill -9 $$"}, {});
  EXPECT_EQ(killed.Wait(), 128 + 9);
  const auto log = std::filesystem::temp_directory_path() /
                   ("process_test_absent_" + std::to_string(getpid()) + ".log");
  ChildProcess::Options missing;
  missing.output = ChildProcess::Output::kLog;
  missing.log = log;
  missing.exec_error = "cannot run: %m";
  ChildProcess absent({"ragdoll-no-such-program"}, missing);
  EXPECT_EQ(absent.Wait(), 127);
  EXPECT_EQ(LastLine(log), "cannot run: No such file or directory");
  std::filesystem::remove(log);
}

TEST(ChildProcess, StreamsInputAndOutputAndSetsTheEnvironment) {
  ChildProcess::Options options;
  options.input = ChildProcess::Input::kPipe;
  options.output = ChildProcess::Output::kPipe;
  options.environment = {{"RAGDOLL_PROCESS_TEST", "set"}, {"HOME", std::nullopt}};
  ChildProcess child({"sh", "-c", "cat; echo \" $RAGDOLL_PROCESS_TEST ${HOME-unset}\""}, options);
  const std::string frame(60000, 'x');  // what one pipe holds: cat's output waits to be read
  EXPECT_TRUE(child.Write(frame.data(), frame.size()));
  child.CloseStdin();
  EXPECT_EQ(child.ReadOutput(), frame + " set unset\n");
  EXPECT_EQ(child.Wait(), 0);
}

TEST(ChildProcess, TerminatesItsWholeGroupAndLeavesNoOrphan) {
  const auto pid_file = std::filesystem::temp_directory_path() /
                        ("process_test_" + std::to_string(getpid()) + ".pid");
  ChildProcess::Options options;
  options.own_group = true;
  // The shell starts a sleep of its own and names it; ending the group ends both.
  ChildProcess child({"sh", "-c", "sleep 30 & echo $! > " + pid_file.string() + "; wait"}, options);
  pid_t grandchild = 0;
  for (int i = 0; i < 500 && grandchild == 0; ++i) {
    std::ifstream(pid_file) >> grandchild;
    if (grandchild == 0) usleep(10000);
  }
  ASSERT_GT(grandchild, 0);
  EXPECT_TRUE(child.Running());
  const auto start = Clock::now();
  EXPECT_EQ(child.Terminate(2), 128 + SIGTERM);
  EXPECT_LT(SecondsSince(start), 2.0);
  for (int i = 0; i < 100 && Alive(grandchild); ++i) usleep(10000);
  EXPECT_FALSE(Alive(grandchild)) << "the group's sleep " << grandchild << " still runs";
  std::filesystem::remove(pid_file);
}

TEST(RunProcess, WaitsLogsAndTimesOut) {
  const auto log = std::filesystem::temp_directory_path() /
                   ("process_test_" + std::to_string(getpid()) + ".log");
  EXPECT_EQ(RunProcess({"sh", "-c", "echo first; echo; echo last >&2; exit 4"}, log, 10), 4);
  EXPECT_EQ(LastLine(log), "last");
  const auto start = Clock::now();
  EXPECT_EQ(RunProcess({"sleep", "30"}, log, 0.3), -1);
  EXPECT_LT(SecondsSince(start), 5.0);
  EXPECT_EQ(RunProcess({"ragdoll-no-such-program"}, log, 10), 127);
  std::filesystem::remove(log);
}

}  // namespace
}  // namespace ragdoll
