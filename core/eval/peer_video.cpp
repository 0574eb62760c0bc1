#include "core/eval/peer_video.h"

extern "C" {
#include <libavutil/cpu.h>
#include <libavutil/pixdesc.h>
#include <libswscale/swscale.h>
}

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/io/video_libav.h"
#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave {
namespace {

struct SwsFree {
    void operator()(SwsContext* context) const { sws_freeContext(context); }
};
using Sws = std::unique_ptr<SwsContext, SwsFree>;

void check_options(const PeerVideoOptions& o, const std::string& where) {
    if (!(o.kbps >= 0 && o.kbps <= 1e7) || std::isnan(o.quality)) {
        throw Error(str(where, ": kbps ", o.kbps, " not in [0, 10^7] or quality ", o.quality,
                        " not a number"));
    }
    if (o.kbps == 0 && o.quality < 0) {
        throw Error(str(where, ": quality ", o.quality, " is negative and no kbps is given"));
    }
    if (o.codec == PeerCodec::snow && o.kbps > 0) {
        throw Error(where +
                    ": FFmpeg's snow rate control ignores the target on easy clips (one "
                    "stream for 10 to 800 kbps), give quality (qscale) and sweep it");
    }
    if (o.codec == PeerCodec::snow && !(o.quality > 0 && o.quality <= 255)) {  // kbps is 0 here
        throw Error(str(where, ": snow's qscale ", o.quality, " is not in (0, 255]"));
    }
    if (o.codec == PeerCodec::vc2 && o.kbps == 0) {
        throw Error(where + ": vc2 has no constant-quality mode, give kbps");
    }
    if (o.codec == PeerCodec::x264 && o.kbps == 0 && o.quality > 51) {
        throw Error(str(where, ": x264's CRF ", o.quality, " is over 51"));
    }
    if (!(o.fps > 0 && o.fps <= 1000)) {
        throw Error(str(where, ": fps ", o.fps, " not in (0, 1000]"));
    }
    if (o.gop < 0 || o.gop > 100000) throw Error(str(where, ": gop ", o.gop, " not in 0..100000"));
    if (o.threads < 0 || o.threads > 64) {
        throw Error(str(where, ": threads ", o.threads, " not in 0..64"));
    }
}

// The encoder, the decoder and the conversions around them, for one clip.
class PeerCodecPair {
  public:
    PeerCodecPair(const PeerVideoOptions& options, int width, int height);

    // Encodes `frame` (nullptr: flushes both codecs) and decodes what comes out.
    void send(const Image* frame, const std::function<void(int, const Image&)>& on_decoded);

    int64_t bytes() const { return bytes_; }

  private:
    void open_encoder();
    void check_vc2_rate(int coded_width, int coded_height) const;
    void open_decoder();
    void decode(const AVPacket* packet, const std::function<void(int, const Image&)>& on_decoded);

    std::string where_;
    PeerVideoOptions options_;
    int width_ = 0;
    int height_ = 0;
    libav::CodecContext encoder_;
    libav::CodecContext decoder_;
    libav::Frame staging_;  // GBRP, the coded (even) size
    libav::Frame yuv_;      // yuv420p, what the encoder takes
    libav::Frame decoded_frame_;
    libav::Frame rgb_;  // GBRP, the input's size
    libav::Packet packet_;
    Sws to_yuv_;
    Sws to_rgb_;
    Image image_;
    int64_t bytes_ = 0;
    int64_t sent_ = 0;
    int decoded_ = 0;
};

const char* encoder_name(PeerCodec codec) {
    return codec == PeerCodec::snow ? "snow" : codec == PeerCodec::vc2 ? "vc2" : "libx264";
}

// FFmpeg's depth (4), lowered until the coarsest chroma band of the 4:2:0 frame is at least 4
// samples a side: FFmpeg 5.1's VC-2 round trip mangles the chroma of smaller bands at any rate
// (at 96x64 and depth 4, chroma comes back at 25 dB PSNR while the luma is lossless); with 4
// samples it is lossless at high rates on every size tried (32x16 to 640x360).
int vc2_wavelet_depth(int coded_width, int coded_height) {
    int depth = 4;
    const auto coarsest = [&](int n) { return (n / 2 + (1 << depth) - 1) >> depth; };
    while (depth > 1 && (coarsest(coded_width) < 4 || coarsest(coded_height) < 4)) --depth;
    return depth;
}

PeerCodecPair::PeerCodecPair(const PeerVideoOptions& options, int width, int height)
    : where_(str(peer_codec_name(options.codec), " peer")),
      options_(options),
      width_(width),
      height_(height),
      packet_(libav::alloc_packet(where_)) {
    libav::silence();
    open_encoder();
    open_decoder();
    const int coded_width = encoder_->width, coded_height = encoder_->height;
    staging_ = libav::alloc_frame(AV_PIX_FMT_GBRP, coded_width, coded_height, where_);
    yuv_ = libav::alloc_frame(AV_PIX_FMT_YUV420P, coded_width, coded_height, where_);
    rgb_ = libav::alloc_frame(AV_PIX_FMT_GBRP, width, height, where_);
    decoded_frame_.reset(av_frame_alloc());
    if (!decoded_frame_) throw Error(where_ + ": out of memory for a frame");
    // VideoWriter's conversion: full-range RGB in, BT.601 limited range out; and VideoReader's
    // inverse, reading the top-left width x height of the padded frame.
    to_yuv_.reset(sws_getContext(
        coded_width, coded_height, AV_PIX_FMT_GBRP, coded_width, coded_height, AV_PIX_FMT_YUV420P,
        SWS_BICUBIC | SWS_ACCURATE_RND | SWS_FULL_CHR_H_INP, nullptr, nullptr, nullptr));
    to_rgb_.reset(sws_getContext(width, height, AV_PIX_FMT_YUV420P, width, height, AV_PIX_FMT_GBRP,
                                 SWS_BICUBIC | SWS_ACCURATE_RND | SWS_FULL_CHR_H_INT, nullptr,
                                 nullptr, nullptr));
    if (!to_yuv_ || !to_rgb_) throw Error(where_ + ": cannot set up the colour conversions");
    const int* bt601 = sws_getCoefficients(SWS_CS_ITU601);
    sws_setColorspaceDetails(to_yuv_.get(), bt601, 1, bt601, 0, 0, 1 << 16, 1 << 16);
    sws_setColorspaceDetails(to_rgb_.get(), bt601, 0, bt601, 1, 0, 1 << 16, 1 << 16);
}

void PeerCodecPair::open_encoder() {
    const PeerVideoOptions& o = options_;
    const AVCodec* codec = avcodec_find_encoder_by_name(encoder_name(o.codec));
    if (!codec) throw Error(str(where_, ": this FFmpeg has no ", encoder_name(o.codec)));
    encoder_.reset(avcodec_alloc_context3(codec));
    if (!encoder_) throw Error(where_ + ": out of memory for the encoder");
    AVCodecContext* enc = encoder_.get();
    const AVRational rate = av_d2q(o.fps, 1001000);
    enc->width = (width_ + 1) & ~1;
    enc->height = (height_ + 1) & ~1;
    enc->pix_fmt = AV_PIX_FMT_YUV420P;
    enc->color_range = AVCOL_RANGE_MPEG;
    enc->colorspace = AVCOL_SPC_SMPTE170M;
    enc->time_base = av_inv_q(rate);
    enc->framerate = rate;
    enc->sample_aspect_ratio = AVRational{1, 1};
    enc->thread_count = o.threads;
    if (o.gop > 0) enc->gop_size = o.gop;
    if (o.codec == PeerCodec::vc2) check_vc2_rate(enc->width, enc->height);
    AVDictionary* settings = nullptr;
    if (o.kbps > 0) {
        enc->bit_rate = std::llround(o.kbps * 1000);
    } else if (o.codec == PeerCodec::snow) {
        // Snow's lambda is qscale * FF_QP2LAMBDA; 0 would select its lossless mode.
        enc->flags |= AV_CODEC_FLAG_QSCALE;
        enc->global_quality = std::max(1, static_cast<int>(std::lround(o.quality * FF_QP2LAMBDA)));
    } else {
        av_dict_set(&settings, "crf", str(o.quality).c_str(), 0);
    }
    if (o.codec == PeerCodec::x264) av_dict_set(&settings, "preset", "medium", 0);
    if (o.codec == PeerCodec::x264 && (av_get_cpu_flags() & AV_CPU_FLAG_AVX512)) {
        // libx264's AVX-512 kernels (libx264 0.164.3095, Debian 12) make its output vary from run
        // to run (on 352x288, 2 to 6 % of the bytes of a 50-frame clip, same input, one thread);
        // x264's AVX2 and SSE paths agree with each other and with themselves.
        av_dict_set(&settings, "x264-params", "asm=AVX2", 0);
    }
    if (o.codec == PeerCodec::vc2) {
        const int depth = vc2_wavelet_depth(enc->width, enc->height);
        av_dict_set(&settings, "wavelet_depth", str(depth).c_str(), 0);
    }
    const int opened = avcodec_open2(enc, codec, &settings);
    const int unused = av_dict_count(settings);
    av_dict_free(&settings);
    libav::check(opened, where_, "cannot open the encoder");
    if (unused) throw Error(where_ + ": the encoder did not take its options");
}

// The smallest frame FFmpeg's vc2 writes: VC-2's high-quality slices code every coefficient,
// a zero in one bit, so at least a bit a sample of the transform (planes padded to a multiple of
// 2^depth), about 12 bytes a slice (quantizer, lengths, alignment) and some 115 bytes of headers
// (parse info, sequence header, FFmpeg's version string). Measured: 1332 bytes at 96x64 (this
// gives 1411), 21470 at 352x288 (21499). At that floor every coefficient is zero: grey frames
// (6 dB on a colour test pattern) larger than the target.
double vc2_floor_bytes(int coded_width, int coded_height) {
    const int depth = vc2_wavelet_depth(coded_width, coded_height);
    const auto padded = [&](int n) { return ((n + (1 << depth) - 1) >> depth) << depth; };
    const double samples = static_cast<double>(padded(coded_width)) * padded(coded_height) +
                           2.0 * padded(coded_width / 2) * padded(coded_height / 2);
    const int slices = (padded(coded_width) / 32) * (padded(coded_height) / 16);
    return 115 + samples / 8 + 12 * slices;
}

void PeerCodecPair::check_vc2_rate(int coded_width, int coded_height) const {
    if (coded_width < 32 || coded_height < 16) {
        throw Error(
            str(where_, ": ", width_, "x", height_, " frames are smaller than vc2's 32x16 slices"));
    }
    const double floor_bytes = vc2_floor_bytes(coded_width, coded_height);
    const double frame_bytes = options_.kbps * 1000 / 8 / options_.fps;
    if (frame_bytes <= floor_bytes) {
        throw Error(str(where_, ": ", options_.kbps, " kbps at ", options_.fps, " fps is ",
                        std::lround(frame_bytes), " bytes a frame, not above vc2's floor of about ",
                        std::lround(floor_bytes), " at ", width_, "x", height_, " (",
                        std::ceil(floor_bytes * 8 * options_.fps / 1000), " kbps)"));
    }
}

void PeerCodecPair::open_decoder() {
    const AVCodec* codec = avcodec_find_decoder(encoder_->codec_id);
    if (!codec) throw Error(where_ + ": this FFmpeg has no decoder for it");
    decoder_.reset(avcodec_alloc_context3(codec));
    AVCodecParameters* parameters = avcodec_parameters_alloc();
    if (!decoder_ || !parameters) {
        avcodec_parameters_free(&parameters);
        throw Error(where_ + ": out of memory for the decoder");
    }
    int copied = avcodec_parameters_from_context(parameters, encoder_.get());
    if (copied >= 0) copied = avcodec_parameters_to_context(decoder_.get(), parameters);
    avcodec_parameters_free(&parameters);
    libav::check(copied, where_, "cannot set up the decoder");
    decoder_->pkt_timebase = encoder_->time_base;
    decoder_->thread_count = 1;
    libav::check(avcodec_open2(decoder_.get(), codec, nullptr), where_, "cannot open the decoder");
}

void PeerCodecPair::send(const Image* frame,
                         const std::function<void(int, const Image&)>& on_decoded) {
    AVFrame* input = nullptr;
    if (frame) {
        libav::check(av_frame_make_writable(staging_.get()), where_, "out of memory");
        libav::check(av_frame_make_writable(yuv_.get()), where_, "out of memory");
        libav::fill_frame(*frame, staging_.get());
        sws_scale(to_yuv_.get(), staging_->data, staging_->linesize, 0, staging_->height,
                  yuv_->data, yuv_->linesize);
        yuv_->pts = sent_++;
        // Snow takes its qscale from each frame, as ffmpeg's command line hands it over.
        yuv_->quality = encoder_->global_quality;
        input = yuv_.get();
    }
    libav::check(avcodec_send_frame(encoder_.get(), input), where_, "the encoder refused a frame");
    for (;;) {
        const int status = avcodec_receive_packet(encoder_.get(), packet_.get());
        if (status == AVERROR(EAGAIN)) return;  // wants the next frame
        if (status == AVERROR_EOF) break;       // flushed: only after send(nullptr)
        libav::check(status, where_, "encoding failed");
        bytes_ += packet_->size;
        decode(packet_.get(), on_decoded);
        av_packet_unref(packet_.get());
    }
    decode(nullptr, on_decoded);  // the encoder is drained: so is the decoder
    bytes_ += encoder_->extradata_size;
    if (decoded_ != sent_) {
        throw Error(str(where_, ": ", sent_, " frames encoded but ", decoded_, " decoded"));
    }
}

void PeerCodecPair::decode(const AVPacket* packet,
                           const std::function<void(int, const Image&)>& on_decoded) {
    libav::check(avcodec_send_packet(decoder_.get(), packet), where_,
                 "the decoder refused a packet");
    for (;;) {
        AVFrame* out = decoded_frame_.get();
        const int status = avcodec_receive_frame(decoder_.get(), out);
        if (status == AVERROR(EAGAIN) || status == AVERROR_EOF) return;
        libav::check(status, where_, "decoding failed");
        if (out->format != AV_PIX_FMT_YUV420P || out->width != encoder_->width ||
            out->height != encoder_->height) {
            const char* name = av_get_pix_fmt_name(static_cast<AVPixelFormat>(out->format));
            throw Error(str(where_, ": the decoder returned a ", out->width, "x", out->height, " ",
                            name ? name : "unknown", " frame"));
        }
        if (out->pts != AV_NOPTS_VALUE && out->pts != decoded_) {
            throw Error(str(where_, ": decoded frame ", decoded_, " has the time stamp of frame ",
                            out->pts));
        }
        sws_scale(to_rgb_.get(), out->data, out->linesize, 0, height_, rgb_->data, rgb_->linesize);
        av_frame_unref(out);
        libav::image_from_frame(rgb_.get(), image_);
        on_decoded(decoded_++, image_);
    }
}

}  // namespace

const char* peer_codec_name(PeerCodec codec) {
    return codec == PeerCodec::snow ? "snow" : codec == PeerCodec::vc2 ? "vc2" : "x264";
}

PeerCodec peer_codec_from_name(const std::string& name) {
    for (PeerCodec c : {PeerCodec::snow, PeerCodec::vc2, PeerCodec::x264}) {
        if (name == peer_codec_name(c)) return c;
    }
    throw Error(str("unknown peer codec '", name, "' (snow, vc2 or x264)"));
}

PeerVideoResult encode_peer_video(const std::function<bool(Image&)>& next_frame,
                                  const std::function<void(int, const Image&)>& on_decoded,
                                  const PeerVideoOptions& options) {
    const std::string where = str(peer_codec_name(options.codec), " peer");
    check_options(options, where);
    Image frame;
    if (!next_frame(frame)) throw Error(where + ": no frames to encode");
    const int width = frame.width, height = frame.height, channels = frame.channels();
    if (width < 1 || height < 1 || width > 16384 || height > 16384) {
        throw Error(str(where, ": frame size ", width, "x", height, " is outside 1..16384"));
    }
    if (channels != 1 && channels != 3 && channels != 4) {
        throw Error(str(where, ": frames have ", channels, " channels (1, 3 or 4)"));
    }
    PeerCodecPair pair(options, width, height);
    int frames = 0;
    do {
        if (frame.width != width || frame.height != height || frame.channels() != channels) {
            throw Error(str(where, ": frame ", frames, " is ", frame.width, "x", frame.height, "x",
                            frame.channels(), ", the clip is ", width, "x", height, "x", channels));
        }
        for (const std::vector<float>& plane : frame.planes) {
            if (plane.size() != static_cast<size_t>(width) * height) {
                throw Error(str(where, ": frame ", frames, " has a plane of ", plane.size(),
                                " samples for ", width, "x", height));
            }
        }
        pair.send(&frame, on_decoded);
        ++frames;
    } while (next_frame(frame));
    pair.send(nullptr, on_decoded);
    return {.bytes = pair.bytes(), .frames = frames};
}

}  // namespace tesswave
