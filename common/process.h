// Other processes: programs the commands run (xvfb-run, rsvg-convert, Blender, ffmpeg) and this
// program started again (the roles of `ragdoll train`, the doctor's and the benchmarks' children).
// One way to start them, so that every child gets its input, output, group and end alike.
#pragma once

#include <signal.h>
#include <sys/types.h>

#include <cstddef>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace ragdoll {

// The running executable: a child that is this program again runs the same build.
inline constexpr char kThisProgram[] = "/proc/self/exe";

// A child process, started at construction and, if still running, ended at destruction (so that
// an exception leaves no orphan behind). It may be polled, waited for, signalled and fed.
class ChildProcess {
 public:
  enum class Input { kInherit, kNull, kPipe };  // kPipe: the parent writes it (Write)
  // kPipe: the parent reads it (ReadOutput); kStderr: into the parent's stderr; kLog: stdout and
  // stderr both into `log`, so that its output stays out of the parent's.
  enum class Output { kInherit, kPipe, kStderr, kLog };

  struct Options {
    // The file to run, args[0] then only its name; empty: args[0], a path or a name in PATH.
    std::string program;
    Input input = Input::kInherit;
    Output output = Output::kInherit;
    std::filesystem::path log;  // with Output::kLog; when it cannot be opened, output is inherited
    bool append = false;        // add to the log (several children share it) instead of replacing
    // A process group of its own, so that our signals reach everything it starts (xvfb-run
    // starts Xvfb); Ctrl-C at the terminal then reaches only us.
    bool own_group = false;
    // Set in the child's environment, or without a value removed from it.
    std::map<std::string, std::optional<std::string>> environment;
    // Pinned to these cores before it runs, so that all its threads are; empty: where we may run.
    std::vector<int> cores;
    // Written to its stderr when the program cannot start (it then exits 127), a "%m" replaced by
    // the reason as in printf: often the only trace of a missing program.
    std::string exec_error;
    double grace_seconds = 5;  // the destructor's wait after SIGTERM before SIGKILL
  };

  // Throws std::runtime_error when no process can be made (a program that cannot start exits 127).
  ChildProcess(const std::vector<std::string>& args, const Options& options);
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  pid_t pid() const { return pid_; }
  // Without blocking; reaps it once it has ended.
  bool Running();
  // Its exit code, 128 + the signal that ended it, or -1 when something else reaped it.
  int Wait();
  // Waits up to `seconds` for it to end; whether it has.
  bool WaitFor(double seconds);
  // waitpid's status once it has ended, for WIFSIGNALED and the like; -1 if reaped elsewhere.
  int status() const { return status_; }
  // To its group when it has one, else to it; nothing once it has ended (its pid may be reused).
  void Signal(int sig);
  // If it still runs: `sig`, up to `grace_seconds` for it to end, then SIGKILL if it still runs
  // or, always, to its group when it has one (what it started may outlive it). Wait()'s code.
  int Terminate(double grace_seconds, int sig = SIGTERM);

  // All of `size` bytes into its stdin pipe; false once it stopped reading (with SIGPIPE
  // ignored, else that signal ends this process).
  bool Write(const void* data, size_t size);
  // Its end of input: a program reading stdin to the end (ffmpeg) finishes.
  void CloseStdin();
  // Its stdout pipe, read until it and what it started have closed it.
  std::string ReadOutput();

 private:
  void Send(int sig);

  pid_t pid_ = -1;
  bool own_group_ = false;
  double grace_seconds_ = 5;
  int stdin_ = -1, stdout_ = -1;  // our ends of its pipes
  bool ended_ = false;
  int status_ = -1;
};

// Waits for `args` (args[0] a path or a name looked up in PATH) run with stdout and stderr into
// `log`, in a process group of its own so that a timeout or Ctrl-C ends everything it started
// (xvfb-run starts Xvfb, render starts ffmpeg). Returns the exit code, 127 when the program could
// not be started, -1 after the timeout; throws when interrupted.
int RunProcess(const std::vector<std::string>& args, const std::filesystem::path& log,
               double timeout_seconds);

// The last non-empty line of a log, for a one-line reason.
std::string LastLine(const std::filesystem::path& log);

}  // namespace ragdoll
