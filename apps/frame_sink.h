// Where the frames of `decode` and `morph` go: a video file through libav (.mp4/.mov H.264, .mkv
// lossless FFV1, .y4m), an animated GIF (.gif, palette per clip), or a folder of numbered PNG
// frames (a path without an extension, or ending in /). Any other extension is refused before
// any work (check_path). Nothing appears at the path until finish(): files are written under a
// temporary name, PNG frames into a temporary folder renamed into place (into an existing folder,
// they replace its frames only: the user's other files there stay).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/io/video_io.h"
#include "core/math/image.h"

namespace tesswave::cli {

// How .mp4/.mov output is coded (--crf, --preset).
struct H264Settings {
    int crf = 18;  // x264's constant rate factor, 0 (lossless) .. 51
    // x264's speed preset. veryfast, not x264's medium: a 30-frame face morph is written in
    // 0.4 s of CPU instead of 1.2 s, and while the frames render rather than after them
    // (medium looks 40 frames ahead), for a file about 7 % larger at the same CRF.
    std::string preset = "veryfast";
};

class FrameSink {
  public:
    FrameSink(const std::string& path, int width, int height, double fps,
              const H264Settings& h264 = {});
    ~FrameSink();
    void write(const Image& frame);
    void finish();
    int64_t frames() const { return frames_; }
    // Throws CLI::ValidationError (exit 2) naming `option` for a path no sink writes.
    static void check_path(const std::string& path, const std::string& option = "--output");
    // True for a folder of PNG frames.
    static bool is_folder_path(const std::string& path);

  private:
    void move_frames_into_place();

    std::string path_, folder_;
    std::unique_ptr<VideoWriter> video_;
    std::unique_ptr<GifWriter> gif_;  // one palette from all the frames
    int64_t frames_ = 0;
    bool finished_ = false;
};

}  // namespace tesswave::cli
