#include "cli/render/video.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <filesystem>
#include <stdexcept>

namespace ragdoll::render {

VideoWriter::VideoWriter(const std::string& path, int width, int height, double fps) : path_(path) {
  const std::string extension = std::filesystem::path(path).extension().string();
  std::vector<std::string> args = {
      "ffmpeg",    "-y",
      "-loglevel", "error",
      "-f",        "rawvideo",
      "-pix_fmt",  "rgb24",
      "-s",        std::to_string(width) + "x" + std::to_string(height),
      "-r",        std::to_string(fps),
      "-i",        "-"};
  if (extension == ".mp4") {
    args.insert(args.end(), {"-c:v", "libx264", "-pix_fmt", "yuv420p", "-crf", "20", "-movflags",
                             "+faststart"});
  } else if (extension == ".gif") {
    args.insert(args.end(),
                {"-vf", "split[a][b];[a]palettegen=stats_mode=diff[p];[b][p]paletteuse"});
  } else if (extension == ".png") {
    args.insert(args.end(), {"-frames:v", "1"});
    single_frame_ = true;
  } else {
    throw std::runtime_error(path + ": write .mp4, .gif or .png");
  }
  args.push_back(path);
  int fds[2];
  if (pipe(fds) != 0) throw std::runtime_error("pipe: " + std::to_string(errno));
  pid_ = fork();
  if (pid_ == 0) {
    dup2(fds[0], STDIN_FILENO);
    close(fds[0]);
    close(fds[1]);
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    execvp("ffmpeg", argv.data());
    _exit(127);
  }
  close(fds[0]);
  pipe_ = fds[1];
  if (pid_ < 0) {
    close(pipe_);
    throw std::runtime_error("cannot start ffmpeg");
  }
  signal(SIGPIPE, SIG_IGN);  // a failed ffmpeg shows as a write error, not a dead process
}

VideoWriter::~VideoWriter() {
  if (pid_ > 0) {
    try {
      Close();
    } catch (const std::exception&) {
    }
  }
}

void VideoWriter::Write(const std::vector<unsigned char>& rgb) {
  if (single_frame_ && frames_ > 0) return;
  size_t sent = 0;
  while (sent < rgb.size()) {
    ssize_t n = write(pipe_, rgb.data() + sent, rgb.size() - sent);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw std::runtime_error(path_ + ": ffmpeg stopped taking frames");
    sent += static_cast<size_t>(n);
  }
  ++frames_;
}

void VideoWriter::Close() {
  if (pid_ <= 0) return;
  close(pipe_);
  int status = 0;
  while (waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
  }
  pid_ = -1;
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw std::runtime_error(
        path_ + ": ffmpeg failed (exit " +
        std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) +
        (WIFEXITED(status) && WEXITSTATUS(status) == 127 ? ", is ffmpeg installed?)" : ")"));
  }
}

}  // namespace ragdoll::render
