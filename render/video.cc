#include "render/video.h"

#include <signal.h>
#include <sys/wait.h>

#include <filesystem>
#include <stdexcept>

#include "common/process.h"

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
  ChildProcess::Options options;
  options.input = ChildProcess::Input::kPipe;
  ffmpeg_ = std::make_unique<ChildProcess>(args, options);
  signal(SIGPIPE, SIG_IGN);  // a failed ffmpeg shows as a write error, not a dead process
}

VideoWriter::~VideoWriter() {
  if (ffmpeg_) {
    try {
      Close();
    } catch (const std::exception&) {
    }
  }
}

void VideoWriter::Write(const std::vector<unsigned char>& rgb) {
  if (single_frame_ && frames_ > 0) return;
  if (!ffmpeg_ || !ffmpeg_->Write(rgb.data(), rgb.size())) {
    throw std::runtime_error(path_ + ": ffmpeg stopped taking frames");
  }
  ++frames_;
}

void VideoWriter::Close() {
  if (!ffmpeg_) return;
  ffmpeg_->CloseStdin();
  ffmpeg_->Wait();
  const int status = ffmpeg_->status();
  ffmpeg_.reset();
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw std::runtime_error(
        path_ + ": ffmpeg failed (exit " +
        std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) +
        (WIFEXITED(status) && WEXITSTATUS(status) == 127 ? ", is ffmpeg installed?)" : ")"));
  }
}

}  // namespace ragdoll::render
