// Frames to a file through ffmpeg: .mp4 (H.264), .gif (with a generated palette) or .png (one
// frame).
#pragma once

#include <memory>
#include <string>
#include <vector>

namespace ragdoll {
class ChildProcess;
}

namespace ragdoll::render {

class VideoWriter {
 public:
  // Starts ffmpeg; throws std::runtime_error for an unknown extension or when it cannot start.
  VideoWriter(const std::string& path, int width, int height, double fps);
  ~VideoWriter();
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;

  // One RGB frame, top row first. A .png takes only the first.
  void Write(const std::vector<unsigned char>& rgb);
  // Waits for ffmpeg; throws std::runtime_error naming the file if it failed.
  void Close();
  int frames() const { return frames_; }
  bool single_frame() const { return single_frame_; }

 private:
  std::string path_;
  std::unique_ptr<ChildProcess> ffmpeg_;  // null once closed
  int frames_ = 0;
  bool single_frame_ = false;
};

}  // namespace ragdoll::render
