// Where decoded frames go: a video file through libav (.mp4/.mov H.264, .mkv FFV1, .y4m) or a
// folder of numbered PNG frames (any other path). Nothing appears at the path until finish():
// video files are written under a temporary name, PNG frames into a temporary folder renamed
// into place.
#pragma once

#include <memory>
#include <string>

#include "core/io/video_io.h"
#include "core/math/image.h"

namespace tesswave::cli {

class FrameSink {
  public:
    FrameSink(const std::string& path, int width, int height, double fps);
    ~FrameSink();
    void write(const Image& frame);
    void finish();
    int64_t frames() const { return frames_; }
    static bool is_video_path(const std::string& path);

  private:
    std::string path_, folder_;
    std::unique_ptr<VideoWriter> video_;
    int64_t frames_ = 0;
    bool finished_ = false;
};

}  // namespace tesswave::cli
