// libav* plumbing shared by video_io.cpp and video_filter.cpp (not a public header): owning
// pointers, error text, Image <-> AVFrame conversion and an encoder feeding an atomic muxer.
#pragma once

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/frame.h>
}

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/math/image.h"

namespace tesswave::libav {

// Silences libav's logging (process-wide) the first time it is called.
void silence();

// libav's text for an AVERROR code.
std::string error_text(int code);

// Throws Error("<where>: <what> (<libav's reason>)") when code < 0; returns code otherwise.
int check(int code, const std::string& where, const std::string& what);

struct FrameFree {
    void operator()(AVFrame* frame) const { av_frame_free(&frame); }
};
struct PacketFree {
    void operator()(AVPacket* packet) const { av_packet_free(&packet); }
};
struct CodecContextFree {
    void operator()(AVCodecContext* context) const { avcodec_free_context(&context); }
};
struct MuxerFree {
    void operator()(AVFormatContext* muxer) const {
        if (muxer->pb) avio_closep(&muxer->pb);
        avformat_free_context(muxer);
    }
};
using Frame = std::unique_ptr<AVFrame, FrameFree>;
using Packet = std::unique_ptr<AVPacket, PacketFree>;
using CodecContext = std::unique_ptr<AVCodecContext, CodecContextFree>;

Frame alloc_frame(AVPixelFormat format, int width, int height, const std::string& where);
Packet alloc_packet(const std::string& where);

// Fills a GBRP, GBRP16 (native endian), RGB24 or BGR0 frame at least as large as `image`
// (1, 3 or 4 channels: grey is replicated, alpha dropped). Columns and rows beyond the image
// repeat its last ones. Samples are round(v * peak) in float, clamped, NaN to 0 (metrics.h).
void fill_frame(const Image& image, AVFrame* frame);

// Makes `image` the 3-channel Image of a GBRP or GBRP16 frame (q / peak, format u8 or u16),
// reusing its storage.
void image_from_frame(const AVFrame* frame, Image& image);

// An encoder feeding a muxer whose file is a temporary beside `path`, renamed to `path` by
// finish(). Use: construct, set encoder()'s fields, open(), send() frames, finish(). The
// destructor of an unfinished Output removes the temporary.
class Output {
  public:
    Output(const std::string& path, const char* muxer_name, const char* encoder_name);
    ~Output();
    Output(const Output&) = delete;
    Output& operator=(const Output&) = delete;

    using Options = std::vector<std::pair<std::string, std::string>>;

    AVCodecContext* encoder() { return encoder_.get(); }
    // Opens the encoder, creates the file and writes the header. Throws Error if the encoder or
    // the muxer leaves an option unused (a misspelt name would otherwise pass silently).
    void open(const Options& encoder_options, const Options& muxer_options);
    // Encodes `frame` (the caller keeps it) and writes the packets the encoder releases.
    void send(const AVFrame* frame);
    void finish();

  private:
    std::string path_;
    std::string temporary_;
    std::unique_ptr<AVFormatContext, MuxerFree> muxer_;
    CodecContext encoder_;
    AVStream* stream_ = nullptr;
    Packet packet_;
    bool committed_ = false;
};

}  // namespace tesswave::libav
