#include "core/io/video_io.h"

extern "C" {
#include <libavutil/imgutils.h>
#include <libavutil/opt.h>
#include <libavutil/pixdesc.h>
#include <libswscale/swscale.h>
}

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <mutex>
#include <string_view>

#include "core/io/file_io.h"
#include "core/io/video_libav.h"
#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave {
namespace libav {

void silence() {
    static std::once_flag once;
    std::call_once(once, [] { av_log_set_level(AV_LOG_QUIET); });
}

std::string error_text(int code) {
    std::array<char, AV_ERROR_MAX_STRING_SIZE> text{};
    av_strerror(code, text.data(), text.size());
    return text.data();
}

int check(int code, const std::string& where, const std::string& what) {
    if (code < 0) throw Error(str(where, ": ", what, " (", error_text(code), ")"));
    return code;
}

Frame alloc_frame(AVPixelFormat format, int width, int height, const std::string& where) {
    Frame frame(av_frame_alloc());
    if (!frame) throw Error(where + ": out of memory for a frame");
    frame->format = format;
    frame->width = width;
    frame->height = height;
    check(av_frame_get_buffer(frame.get(), 0), where,
          str("cannot allocate a ", width, "x", height, " frame"));
    return frame;
}

Packet alloc_packet(const std::string& where) {
    Packet packet(av_packet_alloc());
    if (!packet) throw Error(where + ": out of memory for a packet");
    return packet;
}

namespace {

// round(v * peak) in float, halves away from zero, clamped; NaN gives 0 (as metrics.cpp).
template <class T>
T quantize(float v, float peak) {
    const float s = std::round(v * peak);
    if (!(s > 0.0f)) return 0;
    return s >= peak ? static_cast<T>(peak) : static_cast<T>(s);
}

// Which channel of `image` feeds R, G and B: grey feeds all three; alpha is never read.
std::array<int, 3> rgb_sources(const Image& image) {
    if (image.channels() < 3) return {0, 0, 0};
    return {0, 1, 2};
}

// Row y of channel c quantized into `out` (width samples, `stride` apart), the last sample
// repeated up to `width`.
template <class T>
void quantize_row(const Image& image, int c, int y, int width, float peak, T* out, int stride) {
    const float* row = image.planes[c].data() + static_cast<size_t>(y) * image.width;
    for (int x = 0; x < image.width; ++x) out[x * stride] = quantize<T>(row[x], peak);
    for (int x = image.width; x < width; ++x) out[x * stride] = out[(image.width - 1) * stride];
}

}  // namespace

void fill_frame(const Image& image, AVFrame* frame) {
    const std::array<int, 3> rgb = rgb_sources(image);
    const auto format = static_cast<AVPixelFormat>(frame->format);
    for (int y = 0; y < frame->height; ++y) {
        const int sy = std::min(y, image.height - 1);
        if (format == AV_PIX_FMT_GBRP || format == AV_PIX_FMT_GBRP16) {
            // Planes are G, B, R.
            const std::array<int, 3> plane_channel = {rgb[1], rgb[2], rgb[0]};
            for (int p = 0; p < 3; ++p) {
                uint8_t* row = frame->data[p] + static_cast<ptrdiff_t>(y) * frame->linesize[p];
                if (format == AV_PIX_FMT_GBRP) {
                    quantize_row(image, plane_channel[p], sy, frame->width, 255.0f, row, 1);
                } else {
                    quantize_row(image, plane_channel[p], sy, frame->width, 65535.0f,
                                 reinterpret_cast<uint16_t*>(row), 1);
                }
            }
        } else if (format == AV_PIX_FMT_RGB24 || format == AV_PIX_FMT_BGR0) {
            uint8_t* row = frame->data[0] + static_cast<ptrdiff_t>(y) * frame->linesize[0];
            const int stride = format == AV_PIX_FMT_RGB24 ? 3 : 4;
            const std::array<int, 3> offset =
                format == AV_PIX_FMT_RGB24 ? std::array{0, 1, 2} : std::array{2, 1, 0};
            for (int k = 0; k < 3; ++k) {
                quantize_row(image, rgb[k], sy, frame->width, 255.0f, row + offset[k], stride);
            }
            if (format == AV_PIX_FMT_BGR0) {
                for (int x = 0; x < frame->width; ++x) row[4 * x + 3] = 0;
            }
        } else {
            throw Error(str("fill_frame: unsupported pixel format ", format));  // internal misuse
        }
    }
}

void image_from_frame(const AVFrame* frame, Image& image) {
    const bool wide = frame->format == AV_PIX_FMT_GBRP16;
    image.width = frame->width;
    image.height = frame->height;
    image.format = wide ? SampleFormat::u16 : SampleFormat::u8;
    image.planes.resize(3);                                 // storage is reused from frame to frame
    const std::array<int, 3> plane_of_channel = {2, 0, 1};  // R, G, B from planes G, B, R
    for (int c = 0; c < 3; ++c) {
        const int p = plane_of_channel[c];
        image.planes[c].resize(static_cast<size_t>(frame->width) * frame->height);
        for (int y = 0; y < frame->height; ++y) {
            const uint8_t* row = frame->data[p] + static_cast<ptrdiff_t>(y) * frame->linesize[p];
            float* out = image.planes[c].data() + static_cast<size_t>(y) * frame->width;
            for (int x = 0; x < frame->width; ++x) {
                // Dividing, not multiplying by the reciprocal: q / 255 exactly as callers write it.
                out[x] =
                    wide ? reinterpret_cast<const uint16_t*>(row)[x] / 65535.0f : row[x] / 255.0f;
            }
        }
    }
}

// ---- Output: encoder + muxer into a temporary --------------------------------------------------

Output::Output(const std::string& path, const char* muxer_name, const char* encoder_name)
    : path_(path), temporary_(temporary_name(path)), packet_(alloc_packet(path)) {
    silence();
    AVFormatContext* muxer = nullptr;
    check(avformat_alloc_output_context2(&muxer, nullptr, muxer_name, nullptr), path,
          str("no ", muxer_name, " muxer in this FFmpeg"));
    muxer_.reset(muxer);
    // The "file:" prefix keeps a ':' in the name from reading as a protocol.
    muxer_->url = av_strdup(("file:" + temporary_).c_str());
    const AVCodec* codec = avcodec_find_encoder_by_name(encoder_name);
    if (!codec) throw Error(str(path, ": this FFmpeg has no ", encoder_name, " encoder"));
    encoder_.reset(avcodec_alloc_context3(codec));
    if (!encoder_ || !muxer_->url) throw Error(path + ": out of memory for the encoder");
}

Output::~Output() {
    muxer_.reset();  // closes the file first
    if (!committed_) discard_temporary(temporary_);
}

namespace {

// Runs open(AVDictionary**) with `options` and throws if it leaves any of them unused.
template <class Open>
void open_with(const Output::Options& options, const std::string& path, Open&& open) {
    AVDictionary* dictionary = nullptr;
    struct Free {  // the open call may replace the dictionary; whichever is left is freed
        AVDictionary*& d;
        ~Free() { av_dict_free(&d); }
    } free{dictionary};
    for (const auto& [key, value] : options) {
        av_dict_set(&dictionary, key.c_str(), value.c_str(), 0);
    }
    open(&dictionary);
    if (const AVDictionaryEntry* e = av_dict_get(dictionary, "", nullptr, AV_DICT_IGNORE_SUFFIX)) {
        throw Error(str(path, ": libav did not take the option ", e->key, "=", e->value));
    }
}

}  // namespace

void Output::open(const Options& encoder_options, const Options& muxer_options) {
    if (muxer_->oformat->flags & AVFMT_GLOBALHEADER) {
        encoder_->flags |= AV_CODEC_FLAG_GLOBAL_HEADER;
    }
    open_with(encoder_options, path_, [&](AVDictionary** options) {
        check(avcodec_open2(encoder_.get(), encoder_->codec, options), path_,
              str("cannot open the ", encoder_->codec->name, " encoder"));
    });
    stream_ = avformat_new_stream(muxer_.get(), nullptr);
    if (!stream_) throw Error(path_ + ": out of memory for a stream");
    check(avcodec_parameters_from_context(stream_->codecpar, encoder_.get()), path_,
          "cannot set the stream parameters");
    stream_->time_base = encoder_->time_base;
    stream_->avg_frame_rate = encoder_->framerate;
    check(avio_open(&muxer_->pb, muxer_->url, AVIO_FLAG_WRITE), path_, "cannot write");
    open_with(muxer_options, path_, [&](AVDictionary** options) {
        check(avformat_write_header(muxer_.get(), options), path_,
              str("cannot start a ", muxer_->oformat->name, " file"));
    });
}

void Output::send(const AVFrame* frame) {
    check(avcodec_send_frame(encoder_.get(), frame), path_, "encoder refused a frame");
    for (;;) {
        const int status = avcodec_receive_packet(encoder_.get(), packet_.get());
        if (status == AVERROR(EAGAIN) || status == AVERROR_EOF) return;
        check(status, path_, "encoding failed");
        av_packet_rescale_ts(packet_.get(), encoder_->time_base, stream_->time_base);
        packet_->stream_index = stream_->index;
        check(av_interleaved_write_frame(muxer_.get(), packet_.get()), path_, "write error");
    }
}

void Output::finish() {
    send(nullptr);
    check(av_write_trailer(muxer_.get()), path_, "cannot finish the file");
    check(avio_closep(&muxer_->pb), path_, "write error");
    commit_temporary(temporary_, path_);
    committed_ = true;
}

}  // namespace libav

// ---- VideoWriter -------------------------------------------------------------------------------

namespace {

struct Container {
    const char* muxer;
    const char* name;  // for messages
};

Container container_for(const std::string& path, VideoCodec codec) {
    const std::string ext = lowercase_extension(path);
    const Container c = ext == ".mp4"   ? Container{"mp4", "MP4"}
                        : ext == ".mov" ? Container{"mov", "QuickTime"}
                        : ext == ".mkv" ? Container{"matroska", "Matroska"}
                        : ext == ".y4m" ? Container{"yuv4mpegpipe", "YUV4MPEG"}
                                        : Container{nullptr, nullptr};
    if (!c.muxer) {
        throw Error(str(path, ": unknown video extension '", ext,
                        "' (.mp4, .mov, .mkv or .y4m; GIFs through write_gif)"));
    }
    const std::string muxer = c.muxer;
    const bool fits = codec == VideoCodec::h264       ? muxer != "yuv4mpegpipe"
                      : codec == VideoCodec::ffv1     ? muxer == "matroska"
                      : codec == VideoCodec::rawvideo ? muxer == "yuv4mpegpipe"
                                                      : false;
    if (!fits) {
        const char* need = codec == VideoCodec::h264   ? ".mp4, .mov or .mkv"
                           : codec == VideoCodec::ffv1 ? ".mkv"
                                                       : ".y4m";
        throw Error(str(path, ": a ", c.name, " file cannot hold this codec (use ", need, ")"));
    }
    return c;
}

void check_writer_options(const std::string& path, int width, int height,
                          const VideoWriterOptions& o) {
    if (width < 1 || height < 1 || width > 16384 || height > 16384) {
        throw Error(str(path, ": frame size ", width, "x", height, " is outside 1..16384"));
    }
    if (!(o.fps > 0 && o.fps <= 1000)) throw Error(str(path, ": fps ", o.fps, " not in (0, 1000]"));
    if (o.crf < 0 || o.crf > 51) throw Error(str(path, ": crf ", o.crf, " is outside 0..51"));
    if (std::find(kX264Presets.begin(), kX264Presets.end(), o.preset) == kX264Presets.end()) {
        throw Error(str(path, ": unknown x264 preset '", o.preset, "'"));
    }
    const bool deep_ok = o.codec == VideoCodec::ffv1 && o.bit_depth == 16;
    if (o.bit_depth != 8 && !deep_ok) {
        throw Error(str(path, ": bit depth ", o.bit_depth, " (8, or 16 with ffv1)"));
    }
}

struct SwsFree {
    void operator()(SwsContext* context) const { sws_freeContext(context); }
};

}  // namespace

struct VideoWriter::State {
    std::string path;
    int width = 0;
    int height = 0;
    libav::Output output;
    libav::Frame staging;  // what fill_frame writes: GBRP for 4:2:0 codecs, else the encoder's
    libav::Frame yuv;      // yuv420p for h264 and rawvideo
    std::unique_ptr<SwsContext, SwsFree> sws;
    int64_t frames = 0;
    bool failed = false;
    bool finished = false;

    State(const std::string& p, const char* muxer, const char* encoder)
        : path(p), output(p, muxer, encoder) {}
};

VideoWriter::VideoWriter(const std::string& path, int width, int height,
                         const VideoWriterOptions& options) {
    check_writer_options(path, width, height, options);
    const Container container = container_for(path, options.codec);
    const bool ffv1 = options.codec == VideoCodec::ffv1;
    // FFmpeg 5.1's YUV4MPEG muxer takes only wrapped_avframe packets, not rawvideo.
    const char* encoder_name = options.codec == VideoCodec::h264 ? "libx264"
                               : ffv1                            ? "ffv1"
                                                                 : "wrapped_avframe";
    state_ = std::make_unique<State>(path, container.muxer, encoder_name);
    State& s = *state_;
    s.width = width;
    s.height = height;
    AVCodecContext* enc = s.output.encoder();
    const AVRational rate = av_d2q(options.fps, 1001000);
    enc->width = ffv1 ? width : (width + 1) & ~1;
    enc->height = ffv1 ? height : (height + 1) & ~1;
    enc->time_base = av_inv_q(rate);
    enc->framerate = rate;
    enc->sample_aspect_ratio = AVRational{1, 1};
    libav::Output::Options encoder_options, muxer_options;
    if (ffv1) {
        enc->pix_fmt = options.bit_depth == 16 ? AV_PIX_FMT_GBRP16 : AV_PIX_FMT_BGR0;
        enc->level = 3;  // FFV1 version 3: slices with CRCs, parameters in the header
        encoder_options = {{"coder", "range_def"}, {"context", "1"}, {"slicecrc", "1"}};
    } else {
        enc->pix_fmt = AV_PIX_FMT_YUV420P;
        enc->color_range = AVCOL_RANGE_MPEG;
        enc->colorspace = AVCOL_SPC_SMPTE170M;
        if (options.codec == VideoCodec::h264) {
            encoder_options = {{"preset", options.preset}, {"crf", str(options.crf)}};
#if defined(__x86_64__)
            // x264's AVX-512 kernels make the stream depend on what its buffers held before (the
            // same frames coded twice in one process gave streams 65-92 dB apart in some frames;
            // with AVX2 or no assembly the same bytes, as without AVX-512): the same command
            // must give the same file, so they are left out.
            if (__builtin_cpu_supports("avx512f"))
                encoder_options.push_back({"x264-params", "asm=AVX2"});
#endif
        }
    }
    if (std::string_view(container.muxer) == "mp4" || std::string_view(container.muxer) == "mov") {
        muxer_options = {{"movflags", "+faststart"}};  // the index first, for streaming players
    }
    s.output.open(encoder_options, muxer_options);
    const AVPixelFormat staging = ffv1 ? enc->pix_fmt : AV_PIX_FMT_GBRP;
    s.staging = libav::alloc_frame(staging, enc->width, enc->height, path);
    if (!ffv1) {
        s.yuv = libav::alloc_frame(AV_PIX_FMT_YUV420P, enc->width, enc->height, path);
        s.sws.reset(sws_getContext(
            enc->width, enc->height, AV_PIX_FMT_GBRP, enc->width, enc->height, AV_PIX_FMT_YUV420P,
            SWS_BICUBIC | SWS_ACCURATE_RND | SWS_FULL_CHR_H_INP, nullptr, nullptr, nullptr));
        if (!s.sws) throw Error(path + ": cannot set up the RGB to YUV conversion");
        // RGB in (full range), BT.601 limited range out, as the stream is tagged.
        const int* bt601 = sws_getCoefficients(SWS_CS_ITU601);
        sws_setColorspaceDetails(s.sws.get(), bt601, 1, bt601, 0, 0, 1 << 16, 1 << 16);
    }
}

VideoWriter::~VideoWriter() = default;
VideoWriter::VideoWriter(VideoWriter&&) noexcept = default;
VideoWriter& VideoWriter::operator=(VideoWriter&&) noexcept = default;

void VideoWriter::write(const Image& frame) {
    if (!state_) throw Error("VideoWriter: used after a move");
    State& s = *state_;
    if (s.failed || s.finished) {
        throw Error(str(s.path, s.failed ? ": writer failed earlier" : ": already finished"));
    }
    s.failed = true;  // until this frame is through
    if (frame.width != s.width || frame.height != s.height) {
        throw Error(str(s.path, ": frame ", s.frames, " is ", frame.width, "x", frame.height,
                        ", the clip is ", s.width, "x", s.height));
    }
    if (frame.channels() != 1 && frame.channels() != 3 && frame.channels() != 4) {
        throw Error(
            str(s.path, ": frame ", s.frames, " has ", frame.channels(), " channels (1, 3 or 4)"));
    }
    libav::check(av_frame_make_writable(s.staging.get()), s.path, "out of memory");
    libav::fill_frame(frame, s.staging.get());
    AVFrame* out = s.staging.get();
    if (s.yuv) {
        libav::check(av_frame_make_writable(s.yuv.get()), s.path, "out of memory");
        sws_scale(s.sws.get(), s.staging->data, s.staging->linesize, 0, s.staging->height,
                  s.yuv->data, s.yuv->linesize);
        out = s.yuv.get();
    }
    out->pts = s.frames;
    s.output.send(out);
    ++s.frames;
    s.failed = false;
}

void VideoWriter::finish() {
    if (!state_) throw Error("VideoWriter: used after a move");
    State& s = *state_;
    if (s.failed || s.finished) {
        throw Error(str(s.path, s.failed ? ": writer failed earlier" : ": already finished"));
    }
    s.failed = true;
    if (s.frames == 0) throw Error(s.path + ": no frames written");
    s.output.finish();
    s.failed = false;
    s.finished = true;
}

int VideoWriter::coded_width() const { return state_->staging->width; }
int VideoWriter::coded_height() const { return state_->staging->height; }
int64_t VideoWriter::frames_written() const { return state_->frames; }

}  // namespace tesswave
