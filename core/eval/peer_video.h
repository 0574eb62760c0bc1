// FFmpeg's video codecs as peers in rate-distortion comparisons: a clip is encoded through
// libavcodec in memory, every packet is decoded back at once, and the caller gets the decoded
// frames (for PSNR/SSIM) and the size of everything the stream holds.
//
// Frames enter as yuv420p, converted as VideoWriter converts them (swscale, BT.601 matrix, limited
// range, bicubic, accurate rounding; samples quantized as metrics.h does), and come back through
// the inverse conversion VideoReader applies, so the peer's numbers include the same colour round
// trip as a clip written with VideoWriter and read with VideoReader. Odd sizes are padded to even
// by repeating the last column or row, as VideoWriter pads, and cropped back after decoding.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "core/math/image.h"

namespace tesswave {

enum class PeerCodec : uint8_t {
    // FFmpeg's Snow: wavelet (9/7) coding of overlapped-block motion-compensated residuals with
    // a range coder, key frame every 12 by default. Quality only: qscale, 0 < quality <= 255
    // (lower is better, fractions allowed; 1 to 16 spans about 35 to 23 dB on small test clips).
    // Its one-pass rate control is not offered: in FFmpeg 5.1 it gives the same stream for any
    // bit rate on easy content (and is capped at qscale 2..31 on the rest); sweep the quality.
    snow,
    // SMPTE VC-2 (Dirac's intra-only profile), FFmpeg's vc2 encoder: 9/7 Deslauriers-Dubuc
    // wavelet, 32x16 slices, the standard's quantization matrix. Depth 4, lowered on small frames
    // (see peer_video.cpp); frames at least 31x15. Rate only: each frame gets its share of the
    // bit rate, less 5 % at most (1 to 2 % measured), unless its finest quantizer needs less
    // (a 352x288 test pattern: 9.2 Mbit/s for 12). A mezzanine codec: every coefficient costs
    // a bit, so rates at or under a floor of about 1.5 bits a pixel plus headers throw Error
    // (96x64 at 25 fps: 282 kbit/s; 352x288: 4.3 Mbit/s). Just above it frames are nearly grey.
    vc2,
    // H.264 through libx264, preset medium, no tune, x264's defaults otherwise; its options SEI
    // (about 700 bytes) is counted. Rate: one-pass ABR, which undershoots on short clips (mb-tree:
    // 0.3 to 0.7 of the target on 10 frames of 96x64, 0.5 to 0.9 on 50 of 352x288). Quality:
    // CRF 0..51 (0: lossless). On CPUs with AVX-512, x264 runs its AVX2 code: its AVX-512
    // kernels make the stream vary from run to run (peer_video.cpp).
    x264,
};

const char* peer_codec_name(PeerCodec codec);  // "snow", "vc2", "x264"
// Throws Error for a name other than those three.
PeerCodec peer_codec_from_name(const std::string& name);

struct PeerVideoOptions {
    PeerCodec codec = PeerCodec::x264;
    double kbps = 0;  // target bit rate in kbit/s (1000 bits); > 0 overrides `quality`
    // snow: qscale in (0, 255], x264: CRF in [0, 51]; used when kbps is 0. The default is x264's
    // own; vc2 has no quality mode and needs kbps.
    double quality = 23;
    double fps = 25;  // 0 < fps <= 1000; with kbps, sets the bits a frame
    int gop = 0;      // frames from one key frame to the next; 0: the codec's default
                      // (snow 12, x264 250); vc2 ignores it (intra only)
    int threads = 1;  // encoder threads; 0: automatic (x264's output then depends on the CPU)
};

struct PeerVideoResult {
    // Every packet's payload plus the codec's extradata (global headers): what a file of the
    // stream would hold without its container.
    int64_t bytes = 0;
    int frames = 0;  // encoded, equal to the frames decoded
};

// Encodes the frames next_frame() hands over until it returns false (the first frame sets the
// size, 1..16384 a side; all must share it; 1, 3 or 4 channels as VideoWriter takes them) and
// calls on_decoded(index, frame) for every decoded frame, in display order, index 0, 1, 2, ...
// (3 channels, the input's size, format u8; valid during the call). The encoder and decoder are
// flushed at the end, so every frame is decoded. Memory holds the codecs' state (x264's lookahead:
// about 50 frames at preset medium) and a frame or two, whatever the clip's length. Throws Error
// for invalid options, no frame, a frame of another size or channel count, and for any failure of
// the codecs, naming the codec.
PeerVideoResult encode_peer_video(const std::function<bool(Image&)>& next_frame,
                                  const std::function<void(int, const Image&)>& on_decoded,
                                  const PeerVideoOptions& options);

}  // namespace tesswave
