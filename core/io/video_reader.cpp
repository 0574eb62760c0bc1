// VideoReader (video_io.h): demux, decode and convert one frame at a time.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <string_view>

extern "C" {
#include <libavutil/pixdesc.h>
#include <libswscale/swscale.h>
}

#include "core/io/video_io.h"
#include "core/io/video_libav.h"
#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave {
namespace {

struct InputClose {
    void operator()(AVFormatContext* context) const { avformat_close_input(&context); }
};
struct SwsFree {
    void operator()(SwsContext* context) const { sws_freeContext(context); }
};

// FFmpeg reads single images through image2 and the *_pipe demuxers (png_pipe, jpeg_pipe, ...).
bool is_still_image_demuxer(std::string_view name) {
    return name == "image2" || (name.size() > 5 && name.substr(name.size() - 5) == "_pipe");
}

// YUV sources get their tagged matrix and range; RGB, grey and palette sources need neither.
bool is_yuv(AVPixelFormat format) {
    const AVPixFmtDescriptor* d = av_pix_fmt_desc_get(format);
    return d && d->nb_components >= 3 && !(d->flags & (AV_PIX_FMT_FLAG_RGB | AV_PIX_FMT_FLAG_PAL));
}

bool is_full_range_yuv(AVPixelFormat format) {
    return format == AV_PIX_FMT_YUVJ420P || format == AV_PIX_FMT_YUVJ422P ||
           format == AV_PIX_FMT_YUVJ444P || format == AV_PIX_FMT_YUVJ440P ||
           format == AV_PIX_FMT_YUVJ411P;
}

}  // namespace

struct VideoReader::State {
    std::string path;
    VideoReaderOptions options;
    std::unique_ptr<AVFormatContext, InputClose> input;
    int stream = -1;
    libav::CodecContext decoder;
    libav::Packet packet;
    libav::Frame decoded;
    libav::Frame rgb;  // GBRP or GBRP16
    std::unique_ptr<SwsContext, SwsFree> sws;
    // What `sws` was set up for: format, matrix and range of the decoded frames.
    std::array<int, 3> sws_source = {AV_PIX_FMT_NONE, 0, 0};
    int width = 0;
    int height = 0;
    int depth = 8;
    bool subsampled = false;
    std::string codec_name;
    int64_t bit_rate = 0;
    int64_t frames = 0;    // returned so far
    bool pending = false;  // `decoded` holds a frame not yet returned
    bool demuxed = false;  // the demuxer is at its end and the decoder has been told

    void open();
    bool decode();
    void convert(Image& frame);
};

void VideoReader::State::open() {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) throw Error(path + ": no such file");
    if (std::filesystem::is_directory(path, ec)) throw Error(path + ": is a directory");
    if (std::filesystem::file_size(path, ec) == 0 && !ec) throw Error(path + ": empty file");
    AVDictionary* dict = nullptr;
    av_dict_set(&dict, "protocol_whitelist", "file", 0);  // never the network
    AVFormatContext* raw = nullptr;
    const int opened = avformat_open_input(&raw, ("file:" + path).c_str(), nullptr, &dict);
    av_dict_free(&dict);
    libav::check(opened, path, "not a readable video file");
    input.reset(raw);
    const std::string_view demuxer = input->iformat->name;
    if (!options.allow_still_images && is_still_image_demuxer(demuxer)) {
        throw Error(str(path, ": a still image (FFmpeg's ", demuxer, " reader), not a video"));
    }
    libav::check(avformat_find_stream_info(input.get(), nullptr), path,
                 "cannot read the stream parameters");
    const AVCodec* codec = nullptr;
    stream = av_find_best_stream(input.get(), AVMEDIA_TYPE_VIDEO, -1, -1, &codec, 0);
    if (stream == AVERROR_STREAM_NOT_FOUND) throw Error(path + ": no video stream");
    if (stream == AVERROR_DECODER_NOT_FOUND) throw Error(path + ": no decoder for its video");
    libav::check(stream, path, "no usable video stream");
    for (unsigned i = 0; i < input->nb_streams; ++i) {
        if (static_cast<int>(i) != stream) input->streams[i]->discard = AVDISCARD_ALL;
    }
    const AVStream* st = input->streams[stream];
    const int64_t pixels = int64_t{st->codecpar->width} * st->codecpar->height;
    if (pixels > options.max_pixels) {
        throw Error(str(path, ": ", st->codecpar->width, "x", st->codecpar->height,
                        " frames exceed the limit of ", options.max_pixels, " pixels"));
    }
    codec_name = avcodec_get_name(st->codecpar->codec_id);
    bit_rate =
        st->codecpar->bit_rate > 0 ? st->codecpar->bit_rate : std::max<int64_t>(input->bit_rate, 0);
    decoder.reset(avcodec_alloc_context3(codec));
    if (!decoder) throw Error(path + ": out of memory for the decoder");
    libav::check(avcodec_parameters_to_context(decoder.get(), st->codecpar), path,
                 "bad stream parameters");
    decoder->pkt_timebase = st->time_base;
    decoder->max_pixels = options.max_pixels;  // the decoder refuses larger frames itself
    decoder->thread_count = 0;
    libav::check(avcodec_open2(decoder.get(), codec, nullptr), path,
                 str("cannot open the ", codec->name, " decoder"));
    packet = libav::alloc_packet(path);
    decoded.reset(av_frame_alloc());
    if (!decoded) throw Error(path + ": out of memory for a frame");
}

// Leaves the next frame in `decoded`; false at the end of the stream.
bool VideoReader::State::decode() {
    for (;;) {
        const int received = avcodec_receive_frame(decoder.get(), decoded.get());
        if (received == 0) return true;
        if (received == AVERROR_EOF) return false;
        if (received != AVERROR(EAGAIN)) {
            if (received == AVERROR_INVALIDDATA) continue;  // a damaged frame: skip it
            libav::check(received, path, str("decoding failed after ", frames, " frames"));
        }
        if (demuxed) return false;  // drained without an EOF (not expected)
        const int read = av_read_frame(input.get(), packet.get());
        if (read == AVERROR_EOF || (read < 0 && input->pb && avio_feof(input->pb))) {
            demuxed = true;
            // A late error from a damaged last packet ends the stream, as a truncation does.
            const int flushed = avcodec_send_packet(decoder.get(), nullptr);
            if (flushed < 0 && flushed != AVERROR_INVALIDDATA) {
                libav::check(flushed, path, "cannot flush the decoder");
            }
            continue;
        }
        libav::check(read, path, str("read error after ", frames, " frames"));
        if (packet->stream_index == stream) {
            const int sent = avcodec_send_packet(decoder.get(), packet.get());
            if (sent < 0 && sent != AVERROR_INVALIDDATA) {
                av_packet_unref(packet.get());
                libav::check(sent, path, str("decoding failed after ", frames, " frames"));
            }
        }
        av_packet_unref(packet.get());
    }
}

void VideoReader::State::convert(Image& frame) {
    const auto format = static_cast<AVPixelFormat>(decoded->format);
    if (decoded->width != width || decoded->height != height) {
        throw Error(str(path, ": frame ", frames, " is ", decoded->width, "x", decoded->height,
                        ", the clip is ", width, "x", height));
    }
    const std::array<int, 3> source = {format, decoded->colorspace, decoded->color_range};
    if (source != sws_source) {
        const AVPixelFormat target = depth > 8 ? AV_PIX_FMT_GBRP16 : AV_PIX_FMT_GBRP;
        sws.reset(sws_getContext(width, height, format, width, height, target,
                                 SWS_BICUBIC | SWS_ACCURATE_RND | SWS_FULL_CHR_H_INT, nullptr,
                                 nullptr, nullptr));
        const char* name = av_get_pix_fmt_name(format);
        if (!sws) {
            throw Error(str(path, ": cannot convert ", name ? name : "its pixels", " to RGB"));
        }
        if (is_yuv(format)) {
            const int full = is_full_range_yuv(format) || decoded->color_range == AVCOL_RANGE_JPEG;
            sws_setColorspaceDetails(sws.get(), sws_getCoefficients(decoded->colorspace), full,
                                     sws_getCoefficients(SWS_CS_DEFAULT), 1, 0, 1 << 16, 1 << 16);
        }
        sws_source = source;
    }
    sws_scale(sws.get(), decoded->data, decoded->linesize, 0, height, rgb->data, rgb->linesize);
    av_frame_unref(decoded.get());
    libav::image_from_frame(rgb.get(), frame);
}

VideoReader::VideoReader(const std::string& path, const VideoReaderOptions& options)
    : state_(std::make_unique<State>()) {
    libav::silence();
    State& s = *state_;
    s.path = path;
    s.options = options;
    s.open();
    if (!s.decode()) throw Error(path + ": no decodable video frame");
    s.pending = true;
    s.width = s.decoded->width;
    s.height = s.decoded->height;
    if (int64_t{s.width} * s.height > options.max_pixels || s.width < 1 || s.height < 1) {
        throw Error(str(path, ": frame size ", s.width, "x", s.height, " is outside the limit"));
    }
    const AVPixFmtDescriptor* d =
        av_pix_fmt_desc_get(static_cast<AVPixelFormat>(s.decoded->format));
    s.depth = d && d->comp[0].depth > 8 ? 16 : 8;
    s.subsampled = d && !(d->flags & AV_PIX_FMT_FLAG_RGB) && d->nb_components >= 3 &&
                   (d->log2_chroma_w > 0 || d->log2_chroma_h > 0);
    s.rgb = libav::alloc_frame(s.depth > 8 ? AV_PIX_FMT_GBRP16 : AV_PIX_FMT_GBRP, s.width, s.height,
                               path);
}

VideoReader::~VideoReader() = default;
VideoReader::VideoReader(VideoReader&&) noexcept = default;
VideoReader& VideoReader::operator=(VideoReader&&) noexcept = default;

int VideoReader::width() const { return state_->width; }
int VideoReader::height() const { return state_->height; }
int VideoReader::bit_depth() const { return state_->depth; }
bool VideoReader::chroma_subsampled() const { return state_->subsampled; }
std::string VideoReader::codec_name() const { return state_->codec_name; }
int64_t VideoReader::bit_rate() const { return state_->bit_rate; }

double VideoReader::fps() const {
    const State& s = *state_;
    const AVRational rate = av_guess_frame_rate(s.input.get(), s.input->streams[s.stream], nullptr);
    return rate.num > 0 && rate.den > 0 ? av_q2d(rate) : 0.0;
}

int64_t VideoReader::frame_count_estimate() const {
    const State& s = *state_;
    const AVStream* st = s.input->streams[s.stream];
    if (st->nb_frames > 0) return st->nb_frames;
    const double rate = fps();
    if (rate <= 0) return -1;
    if (st->duration > 0) return std::llround(st->duration * av_q2d(st->time_base) * rate);
    if (s.input->duration > 0) return std::llround(s.input->duration / double{AV_TIME_BASE} * rate);
    return -1;
}

bool VideoReader::read(Image& frame) {
    State& s = *state_;
    if (!s.pending && !s.decode()) return false;
    s.pending = false;
    s.convert(frame);
    ++s.frames;
    return true;
}

}  // namespace tesswave
