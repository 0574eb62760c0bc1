// Clips read frame by frame from whatever holds them: a video file FFmpeg reads, a folder of
// numbered images, or raw planar YUV. Frames are Images with 3 channels (R, G, B), and memory
// holds one frame (plus a video decoder's references) whatever the clip's length.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "core/math/image.h"

namespace tesswave {

struct FrameSourceOptions {
    // Frames a second: > 0 overrides the clip's own; 0 takes the video file's (0 if it has none)
    // or 25 for folders and raw YUV. At most 1000.
    double fps = 0;
    // Raw .yuv only (ignored otherwise): the frame size, which the file does not carry, and the
    // layout: "yuv420p", "yuv422p", "yuv444p" (8-bit planar, BT.601 limited range) or "gray"
    // (8-bit, full range: q / 255, as FFmpeg's gray).
    int width = 0;
    int height = 0;
    std::string pixel_format = "yuv420p";
    int64_t max_pixels = int64_t{1} << 28;  // a frame; checked before anything is allocated
};

// What the path names is told apart as follows:
// - a directory: every regular file in it with an image extension (png, jpg, jpeg, tif, tiff,
//   bmp, ppm, pgm, exr, webp; any case) is a frame, in natural order (frame2 before frame10),
//   read with read_image(). Grey becomes R = G = B, alpha is dropped; the sample format is the
//   file's. Other files in the folder are not looked at.
// - a file ending in .yuv (any case): raw planar frames back to back, converted with swscale as
//   VideoReader converts YUV (BT.601 matrix, limited range, bicubic chroma). Only whole frames
//   are read; trailing_bytes() tells what is left over.
// - any other file: a VideoReader (video_io.h); .y4m, .mkv, .mp4 and the rest.
// A moved-from source may only be destroyed or assigned to.
class FrameSource {
  public:
    // Decodes (or reads) the first frame, so that the size is known. Throws Error naming the
    // path for a missing or unreadable input, an empty folder, a clip without frames, a .yuv
    // without a size or with an unknown pixel format, a .yuv shorter than one frame, a frame
    // over max_pixels or an fps outside (0, 1000].
    explicit FrameSource(const std::string& path, const FrameSourceOptions& options = {});
    ~FrameSource();
    FrameSource(FrameSource&&) noexcept;
    FrameSource& operator=(FrameSource&&) noexcept;

    int width() const;
    int height() const;
    double fps() const;
    // Exact for folders and raw YUV; for video files VideoReader's estimate (-1: unknown).
    int64_t frame_count_estimate() const;
    // Raw YUV: the bytes after the last whole frame, which are not read (the caller may warn).
    // 0 for other inputs.
    int64_t trailing_bytes() const;
    // Whether the source's chroma has fewer samples than its luma (a 4:2:0 or 4:2:2 video file
    // or raw .yuv); false for image folders and 4:4:4.
    bool chroma_subsampled() const;
    // A video file's codec as FFmpeg names it and its bits a pixel (bit rate over pixels a
    // second; 0 unknown); "" and 0 for folders and raw YUV.
    std::string source_codec() const;
    double source_bits_per_pixel() const;

    // Fills `frame` with the next frame (3 channels, width() x height()) and returns true, or
    // returns false at the end. Throws Error("<path>: frame 7 is 320x240, the clip is 352x288")
    // when a frame's size differs from the first one's, naming the image file for folders, and
    // Error for an unreadable image or a short read.
    bool read(Image& frame);

  private:
    struct State;
    std::unique_ptr<State> state_;
};

}  // namespace tesswave
