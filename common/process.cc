#include "common/process.h"

#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <initializer_list>
#include <stdexcept>
#include <thread>

namespace ragdoll {
namespace fs = std::filesystem;
namespace {

volatile sig_atomic_t g_interrupted = 0;
void OnInterrupt(int) { g_interrupted = 1; }

// How often a wait with a time limit looks: fine enough for grace periods of seconds.
constexpr auto kPoll = std::chrono::milliseconds(20);

// The parent's environment with `changes` made, as execve takes it.
std::vector<std::string> ChangedEnvironment(
    const std::map<std::string, std::optional<std::string>>& changes) {
  std::vector<std::string> out;
  for (char** entry = environ; *entry != nullptr; ++entry) {
    const std::string text = *entry;
    if (changes.count(text.substr(0, text.find('='))) == 0) out.push_back(text);
  }
  for (const auto& [name, value] : changes) {
    if (value) out.push_back(name + "=" + *value);
  }
  return out;
}

// The strings as exec takes them: pointers into `strings`, then null.
std::vector<char*> Pointers(std::vector<std::string>& strings) {
  std::vector<char*> out;
  for (auto& s : strings) out.push_back(s.data());
  out.push_back(nullptr);
  return out;
}

void CloseAll(std::initializer_list<int> fds) {
  for (int fd : fds) {
    if (fd >= 0) close(fd);
  }
}

// The child's side, all of it made before fork: between fork and exec only system calls run,
// since the parent's other threads may hold locks (the allocator's) that the child inherits.
struct ChildSide {
  std::vector<std::string> arg_strings, env_strings;
  std::vector<char*> argv, envp;  // envp empty: the parent's environment
  const char* program = nullptr;  // with `search`, looked up in PATH
  bool search = false, own_group = false, pin = false, out_to_err = false;
  cpu_set_t cores;
  int in = -1, out = -1, log = -1;  // to become stdin, stdout, stdout and stderr
  std::string before, after;        // the exec error around its reason
  bool reason = false;

  ChildSide(const std::vector<std::string>& args, const ChildProcess::Options& options)
      : arg_strings(args), argv(Pointers(arg_strings)) {
    if (!options.environment.empty()) {
      env_strings = ChangedEnvironment(options.environment);
      envp = Pointers(env_strings);
    }
    search = options.program.empty();
    program = search ? argv[0] : options.program.c_str();
    own_group = options.own_group;
    pin = !options.cores.empty();
    CPU_ZERO(&cores);
    for (int core : options.cores) CPU_SET(core, &cores);
    out_to_err = options.output == ChildProcess::Output::kStderr;
    const size_t at = options.exec_error.find("%m");
    reason = at != std::string::npos;
    before = options.exec_error.substr(0, at);
    if (reason) after = options.exec_error.substr(at + 2);
  }

  // After fork, in the child.
  [[noreturn]] void Run() const {
    if (own_group) setpgid(0, 0);
    if (pin) sched_setaffinity(0, sizeof cores, &cores);
    if (in >= 0) MoveTo(in, STDIN_FILENO);
    if (out >= 0) MoveTo(out, STDOUT_FILENO);
    if (out_to_err) dup2(STDERR_FILENO, STDOUT_FILENO);
    if (log >= 0) {
      MoveTo(log, STDOUT_FILENO);
      dup2(STDOUT_FILENO, STDERR_FILENO);
    }
    if (envp.empty() && search) {
      execvp(program, argv.data());
    } else if (envp.empty()) {
      execv(program, argv.data());
    } else if (search) {
      execvpe(program, argv.data(), envp.data());
    } else {
      execve(program, argv.data(), envp.data());
    }
    const int error = errno;
    Say(before.data(), before.size());
    if (reason) Say(strerror(error), std::strlen(strerror(error)));
    Say(after.data(), after.size());
    _exit(127);
  }

  // In the child: `fd` becomes `target`, open across exec (dup2 clears close-on-exec, but not on
  // an fd duplicated onto itself).
  static void MoveTo(int fd, int target) {
    if (fd == target) {
      fcntl(fd, F_SETFD, 0);
    } else {
      dup2(fd, target);
    }
  }

  // In the child: `text` to stderr, as far as it goes.
  static void Say(const char* text, size_t size) {
    while (size > 0) {
      const ssize_t n = write(STDERR_FILENO, text, size);
      if (n <= 0) return;
      text += n;
      size -= static_cast<size_t>(n);
    }
  }
};

}  // namespace

ChildProcess::ChildProcess(const std::vector<std::string>& args, const Options& options)
    : own_group_(options.own_group), grace_seconds_(options.grace_seconds) {
  if (args.empty()) throw std::invalid_argument("a process needs at least its name");
  ChildSide child(args, options);
  // Our ends of the pipes close in the child and in every program started later; the child's
  // ends, the log and /dev/null move to 0, 1 and 2, where they stay open.
  int in[2] = {-1, -1}, out[2] = {-1, -1};
  if ((options.input == Input::kPipe && pipe2(in, O_CLOEXEC) != 0) ||
      (options.output == Output::kPipe && pipe2(out, O_CLOEXEC) != 0)) {
    const int error = errno;
    CloseAll({in[0], in[1], out[0], out[1]});
    throw std::runtime_error("pipe: " + std::to_string(error));
  }
  child.in = options.input == Input::kNull ? open("/dev/null", O_RDONLY | O_CLOEXEC) : in[0];
  child.out = out[1];
  if (options.output == Output::kLog) {
    const int mode = O_WRONLY | O_CREAT | O_CLOEXEC | (options.append ? O_APPEND : O_TRUNC);
    child.log = open(options.log.c_str(), mode, 0644);
  }
  pid_ = fork();
  if (pid_ == 0) child.Run();
  CloseAll({child.in, child.out, child.log});
  if (pid_ < 0) {
    CloseAll({in[1], out[0]});
    throw std::runtime_error("cannot start " + args[0]);
  }
  // Also here: the child may not have run yet when we signal its group.
  if (own_group_) setpgid(pid_, pid_);
  stdin_ = in[1];
  stdout_ = out[0];
}

ChildProcess::~ChildProcess() {
  CloseStdin();
  CloseAll({stdout_});
  if (Running()) Terminate(grace_seconds_);
}

bool ChildProcess::Running() {
  if (ended_) return false;
  int status = 0;
  pid_t reaped;
  while ((reaped = waitpid(pid_, &status, WNOHANG)) < 0 && errno == EINTR) {
  }
  if (reaped == 0) return true;
  ended_ = true;
  status_ = reaped == pid_ ? status : -1;  // -1: another waitpid reaped it (ECHILD)
  return false;
}

int ChildProcess::Wait() {
  if (!ended_) {
    int status = 0;
    pid_t reaped;
    while ((reaped = waitpid(pid_, &status, 0)) < 0 && errno == EINTR) {
    }
    ended_ = true;
    status_ = reaped == pid_ ? status : -1;
  }
  if (status_ == -1) return -1;
  return WIFEXITED(status_) ? WEXITSTATUS(status_) : 128 + WTERMSIG(status_);
}

bool ChildProcess::WaitFor(double seconds) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (Running()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(kPoll);
  }
  return true;
}

void ChildProcess::Send(int sig) { kill(own_group_ ? -pid_ : pid_, sig); }

void ChildProcess::Signal(int sig) {
  if (Running()) Send(sig);
}

int ChildProcess::Terminate(double grace_seconds, int sig) {
  if (!Running()) return Wait();
  Send(sig);
  WaitFor(grace_seconds);
  // What ignored `sig` (render finishes its frames otherwise), and what the child left behind.
  if (own_group_ || Running()) Send(SIGKILL);
  return Wait();
}

bool ChildProcess::Write(const void* data, size_t size) {
  const char* bytes = static_cast<const char*>(data);
  while (size > 0) {
    const ssize_t n = write(stdin_, bytes, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    bytes += n;
    size -= static_cast<size_t>(n);
  }
  return true;
}

void ChildProcess::CloseStdin() {
  CloseAll({stdin_});
  stdin_ = -1;
}

std::string ChildProcess::ReadOutput() {
  std::string text;
  char buffer[4096];
  while (stdout_ >= 0) {
    const ssize_t n = read(stdout_, buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    text.append(buffer, static_cast<size_t>(n));
  }
  CloseAll({stdout_});
  stdout_ = -1;
  return text;
}

std::string LastLine(const fs::path& log) {
  std::ifstream in(log);
  std::string line, last;
  while (std::getline(in, line)) {
    if (line.find_first_not_of(" \t\r") != std::string::npos) last = line;
  }
  return last;
}

int RunProcess(const std::vector<std::string>& args, const fs::path& log, double timeout_seconds) {
  ChildProcess::Options options;
  options.input = ChildProcess::Input::kNull;
  options.output = ChildProcess::Output::kLog;
  options.log = log;
  options.own_group = true;
  options.exec_error = "cannot run " + args[0] + "\n";
  ChildProcess child(args, options);

  // Ctrl-C ends the child's group and the report; the previous handlers come back afterwards.
  struct sigaction interrupt = {}, old_int = {}, old_term = {};
  interrupt.sa_handler = OnInterrupt;
  sigemptyset(&interrupt.sa_mask);
  g_interrupted = 0;
  sigaction(SIGINT, &interrupt, &old_int);
  sigaction(SIGTERM, &interrupt, &old_term);
  const auto start = std::chrono::steady_clock::now();
  int code = -1;
  while (true) {
    if (!child.Running()) {
      code = child.Wait();
      break;
    }
    const double waited =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (g_interrupted || waited > timeout_seconds) {
      child.Terminate(3);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  sigaction(SIGINT, &old_int, nullptr);
  sigaction(SIGTERM, &old_term, nullptr);
  if (g_interrupted) throw std::runtime_error(args[0] + ": interrupted");
  return code;
}

}  // namespace ragdoll
