// Video files through FFmpeg's libav*: writing clips (H.264 MP4, lossless FFV1, Y4M) and GIFs,
// reading any clip FFmpeg reads one frame at a time, and FFmpeg's motion-compensated
// interpolation (`minterpolate`) as the in-between peer (DESIGN.md 6).
//
// Frames are Images: planar float RGB in [0,1]. Writers accept 1, 3 or 4 channels (grey is
// replicated to R, G and B; alpha is dropped) and quantize each sample as metrics.h does,
// round(v * peak) in float, clamped to [0, peak], NaN to 0. Readers return 3 channels (R, G, B).
// RGB <-> YUV conversions use swscale with the BT.601 matrix, limited range, unless a file tags
// another matrix or range, which the reader then honours.
//
// Every function throws Error("<path>: ...") on failure. Outputs go to a temporary name beside
// the target and are renamed into place when complete, so a failure leaves no file behind.
// libav's own logging is silenced (av_log_set_level(AV_LOG_QUIET), process-wide) on first use.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/math/image.h"

namespace tesswave {

enum class VideoCodec : uint8_t {
    // libx264, yuv420p (BT.601, limited range, tagged so), CRF rate control; .mp4, .mov or .mkv.
    // 4:2:0 needs even sizes: an odd width or height is padded by repeating the last column or
    // row, so the file is one pixel wider or taller (VideoWriter::coded_width/coded_height).
    h264,
    // Lossless FFV1 (version 3, range coder) in RGB: bgr0 at 8 bits, gbrp16 at 16; .mkv only.
    // Reading back gives the quantized samples exactly.
    ffv1,
    // Uncompressed yuv420p (BT.601, limited range) in YUV4MPEG, the input format of most
    // encoders; .y4m only. Odd sizes are padded as for h264.
    rawvideo,
};

// x264's speed presets, fastest first: what VideoWriterOptions::preset accepts.
inline constexpr std::array<const char*, 10> kX264Presets = {
    "ultrafast", "superfast", "veryfast", "faster",   "fast",
    "medium",    "slow",      "slower",   "veryslow", "placebo"};

struct VideoWriterOptions {
    double fps = 25;  // 0 < fps <= 1000; stored as the fraction av_d2q(fps, 1001000)
    VideoCodec codec = VideoCodec::h264;
    int crf = 18;                   // h264: x264's constant rate factor, 0 (lossless) .. 51
    std::string preset = "medium";  // h264: x264's speed preset, ultrafast .. placebo
    int bit_depth = 8;              // ffv1: 8 or 16 bits a sample; h264 and rawvideo: 8
};

// Writes a clip frame by frame; the container comes from the extension of `path`. Nothing
// appears at `path` until finish() succeeds; the destructor of an unfinished writer removes
// its temporary. After an Error from write() or finish() the writer is failed: later calls
// throw again and nothing is written. A moved-from writer may only be destroyed or assigned to.
class VideoWriter {
  public:
    // Throws Error for an unknown extension, a codec the container cannot hold, an unwritable
    // directory, sizes outside 1..16384 or invalid options.
    VideoWriter(const std::string& path, int width, int height,
                const VideoWriterOptions& options = {});
    ~VideoWriter();
    VideoWriter(VideoWriter&&) noexcept;
    VideoWriter& operator=(VideoWriter&&) noexcept;

    // `frame` must be width x height with 1, 3 or 4 channels.
    void write(const Image& frame);
    // Flushes the encoder, writes the trailer and renames the temporary to `path`. Throws Error
    // if no frame was written.
    void finish();

    int coded_width() const;   // the size in the file: width and height rounded up to even
    int coded_height() const;  // for h264 and rawvideo, unchanged for ffv1
    int64_t frames_written() const;

  private:
    struct State;
    std::unique_ptr<State> state_;
};

struct GifOptions {
    int loop = 0;  // 0: loop forever, -1: play once, n: repeat n times
    // paletteuse's dither: bayer, heckbert, floyd_steinberg, sierra2, sierra2_4a or none.
    std::string dither = "sierra2_4a";
    int max_colors = 256;  // 4..256, one palette for the whole clip
};

// Writes an animated GIF through one libavfilter graph that builds a single palette from every
// frame and dithers each frame with it:
//
//   split[a][b];[a]palettegen=stats_mode=full:max_colors=M:reserve_transparent=0[p];
//   [b][p]paletteuse=dither=D
//
// (gif_filter() returns the exact string), then the gif encoder and muxer. GIF delays are whole
// centiseconds; the muxer rounds each frame's time, so 25 fps is exact and 30 fps alternates
// 3 and 4 cs. Frames must share one size, 1..16384 a side. Alpha is dropped (opaque GIF).
void write_gif(const std::vector<Image>& frames, const std::string& path, double fps,
               const GifOptions& options = {});
std::string gif_filter(const GifOptions& options = {});

// The same GIF, given a frame at a time: the filter graph keeps each frame as RGB24 (3 bytes a
// pixel) until finish() has the palette, so the caller need not hold the frames (a 300-frame
// morph held them as float planes: 734 MB). Throws Error as write_gif does; a writer destroyed
// before finish() leaves no file.
class GifWriter {
  public:
    GifWriter(const std::string& path, int width, int height, double fps,
              const GifOptions& options = {});
    ~GifWriter();
    void write(const Image& frame);
    void finish();

  private:
    struct State;
    std::unique_ptr<State> state_;
};

struct VideoReaderOptions {
    int64_t max_pixels = int64_t{1} << 28;  // a frame; checked before the decoder allocates
    // Single-image inputs (FFmpeg's image2 and *_pipe demuxers: a PNG, JPEG, ... possibly
    // renamed to .mp4) are rejected unless allowed: stills belong to read_image().
    bool allow_still_images = false;
};

// Reads the video stream FFmpeg ranks best (av_find_best_stream) in any local file it can demux
// and decode, one frame at a time: memory holds the decoder's reference frames and one output
// frame, whatever the clip's length. The constructor decodes the first frame, so a file with no
// decodable frame fails at once. Frames come out in presentation order, as the decoder emits
// them. A moved-from reader may only be destroyed or assigned to.
class VideoReader {
  public:
    // Throws Error naming the file when it is missing, not a readable media file, has no video
    // stream, a frame over the pixel limit or no decodable frame.
    explicit VideoReader(const std::string& path, const VideoReaderOptions& options = {});
    ~VideoReader();
    VideoReader(VideoReader&&) noexcept;
    VideoReader& operator=(VideoReader&&) noexcept;

    int width() const;
    int height() const;
    double fps() const;  // FFmpeg's guess from the stream's rates; 0 if unknown
    // The container's frame count, else duration x fps rounded; -1 if neither is known.
    int64_t frame_count_estimate() const;
    // 8, or 16 when the stream has more than 8 bits a sample; frames then have format u16.
    int bit_depth() const;
    // Whether the stream's chroma has fewer samples than its luma (4:2:0, 4:2:2, 4:1:1).
    bool chroma_subsampled() const;
    // The stream's codec as FFmpeg names it ("h264", "vp8", "rawvideo", ...), and its bit rate in
    // bits a second: the stream's, else the container's; 0 when neither is known.
    std::string codec_name() const;
    int64_t bit_rate() const;

    // Fills `frame` with the next frame (3 channels, width x height) and returns true, or
    // returns false at the end of the clip. Corrupt packets are skipped, as FFmpeg does. Throws
    // Error if a frame changes size mid-stream.
    bool read(Image& frame);

  private:
    struct State;
    std::unique_ptr<State> state_;
};

struct MinterpolateOptions {
    std::string mc_mode = "obmc";   // obmc | aobmc
    std::string me_mode = "bilat";  // bilat | bidir
    std::string me = "epzs";        // esa tss tdls ntss fss ds hexbs epzs umh
    int mb_size = 16;               // 4, 8 or 16; frames must be at least 2 * mb_size a side
    int search_param = 32;          // 4..1024
    bool vsbmc = false;             // variable-size block motion compensation
    // FFmpeg's default (fdiff) turns an in-between of two different enough images into a copy
    // of the nearer one; off here, so that the peer always interpolates.
    bool scene_change_detection = false;
};

// The frame half-way between frame0 and frame1 by FFmpeg's motion-compensated interpolation.
// Frames (same size, 1, 3 or 4 channels) enter a libavfilter graph as gbrp (8-bit planar RGB)
// at 1 fps with pts 0, 1 and 2 (frame1 twice: minterpolate interpolates between the 2nd and 3rd
// of the four frames it holds and has no end-of-stream flush in FFmpeg 5.1), through
//
//   format=yuvj444p,minterpolate=fps=2:mi_mode=mci:mc_mode=obmc:me_mode=bilat:me=epzs:
//   mb_size=16:search_param=32:vsbmc=0:scd=none,format=gbrp
//
// (minterpolate_filter() returns the exact string); the output frame with pts 1 in time base
// 1/2 is the middle one. minterpolate works on 8-bit YUV only: the full-range 4:4:4 round trip
// costs about half a level. Returns 3 channels, format u8.
Image minterpolate_middle(const Image& frame0, const Image& frame1,
                          const MinterpolateOptions& options = {});
std::string minterpolate_filter(const MinterpolateOptions& options = {});

}  // namespace tesswave
