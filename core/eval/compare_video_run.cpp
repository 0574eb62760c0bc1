// One run of `tesswave compare-video`: a clip coded with one method at one rate, decoded and
// measured frame by frame, with one FrameSource for the input and another for the reference, so
// that memory holds a frame or two whatever the clip's length.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <optional>

#include "core/eval/compare_video.h"
#include "core/eval/peer_video.h"
#include "core/math/error.h"
#include "core/math/metrics.h"
#include "core/math/strings.h"
#include "video/dec_video.h"
#include "video/enc_video.h"

namespace fs = std::filesystem;

namespace tesswave::eval {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
}

// A frame identical to its reference would make the mean infinite; like x264's PSNR Mean, it
// counts as 100 dB.
constexpr double kMaxPsnr = 100;

// The sample metrics.h compares: round(v * 255) in float, halves up, clamped.
double quantized(float v) { return std::clamp(std::floor(v * 255.0f + 0.5f), 0.0f, 255.0f); }

class QualityMeter {
  public:
    void add(const Image& reference, const Image& test) {
        psnr_y_ += luma_psnr(reference, test);
        psnr_ += std::min(kMaxPsnr, psnr(reference, test).all);
        ssim_ += ssim(reference, test).all;
        ++frames_;
    }
    void fill(VideoRow& row) const {
        row.frames = frames_;
        row.psnr_y = psnr_y_ / frames_;
        row.psnr = psnr_ / frames_;
        row.ssim = ssim_ / frames_;
    }

  private:
    double psnr_y_ = 0, psnr_ = 0, ssim_ = 0;
    int64_t frames_ = 0;
};

VideoRow start_row(const RunContext& c, VideoMethod method, double target_bpp) {
    VideoRow row;
    row.clip = c.clip->name;
    row.method = method_label(method);
    row.target_bpp = target_bpp;
    return row;
}

void finish_row(VideoRow& row, const ClipInfo& clip) {
    row.bpp = row.bytes * 8.0 / clip.pixels();
    row.kbps = row.bytes * 8.0 / 1000 / (clip.frames / clip.fps);
}

double kbps_for(const ClipInfo& clip, double bpp) {
    return bpp * clip.width * clip.height * clip.fps / 1000;
}

// Encodes into a .twv stream and returns its size; the time goes to row.encode_s.
int64_t encode_ours(const RunContext& c, VideoMethod method, double target_bpp,
                    const std::string& stream, VideoRow& row) {
    const ClipInfo& clip = *c.clip;
    video::VideoEncodeOptions o{.transform = method == VideoMethod::grid53   ? TwiTransform::grid53
                                             : method == VideoMethod::grid97 ? TwiTransform::grid97
                                                                             : TwiTransform::mesh,
                                .motion = method == VideoMethod::moving_mesh
                                              ? video::TwvMotion::tracked
                                              : video::TwvMotion::none,
                                .mesh_wavelet = c.mesh_wavelet,
                                .group = c.group,
                                .chroma_420 = clip.chroma_420,
                                .kbps = kbps_for(clip, target_bpp),
                                .grid_groups = method == VideoMethod::moving_mesh && !c.mesh_only};
    o.sampling = c.sampling;
    FrameSource source(clip.path, c.source);
    video::VideoEncoder encoder(stream, clip.width, clip.height, clip.fps, o);
    Image frame;
    double seconds = 0;
    video::GroupCount groups;
    const auto count = [&](const std::vector<video::EncodedFrame>& done) {
        for (const video::EncodedFrame& f : done) groups.add(f);
    };
    for (int64_t n = 0; n < clip.frames && source.read(frame); ++n) {
        const auto start = Clock::now();
        count(encoder.encode(frame));
        seconds += seconds_since(start);
        c.progress(0.8 * (n + 1) / clip.frames, "encoding");
    }
    const auto start = Clock::now();
    count(encoder.flush());
    const int64_t bytes = encoder.finish();
    row.encode_s = seconds + seconds_since(start);
    // Which groups left the method's own domain (the moving mesh's choices).
    row.setting = str("kbps ", std::lround(o.kbps * 100) / 100.0);
    if (groups.static_groups > 0) {
        row.setting += str(", ", groups.static_groups, "/", groups.groups, " groups static");
    }
    if (groups.grid_groups > 0) {
        row.setting += str(", ", groups.grid_groups, "/", groups.groups, " groups grid");
    }
    if (groups.canvas_groups > 0) {
        row.setting += str(", ", groups.canvas_groups, "/", groups.groups, " groups on a canvas");
    }
    return bytes;
}

// Decodes the stream written by encode_ours and measures it; the time goes to row.decode_s.
void decode_ours(const RunContext& c, const std::string& stream, VideoRow& row, Image* shown) {
    const ClipInfo& clip = *c.clip;
    video::VideoDecoder decoder(stream);
    FrameSource reference(clip.path, c.source);
    QualityMeter meter;
    Image decoded, frame;
    double seconds = 0;
    int64_t n = 0;
    for (; n < clip.frames; ++n) {
        const auto start = Clock::now();
        const bool more = decoder.read(decoded);
        seconds += seconds_since(start);
        if (!more || !reference.read(frame)) break;
        meter.add(frame, decoded);
        if (n == clip.shown_frame && shown) *shown = decoded;
        c.progress(0.8 + 0.2 * (n + 1) / clip.frames, "decoding");
    }
    if (n < clip.frames) {
        throw Error(
            str(stream, ": decoded ", n, " of ", clip.frames, " frames ", decoder.damage()));
    }
    row.decode_s = seconds;
    meter.fill(row);
}

VideoRow run_ours(const RunContext& c, VideoMethod method, double target_bpp, Image* shown) {
    VideoRow row = start_row(c, method, target_bpp);
    const std::string stream = (fs::path(c.scratch_dir) / str(method_id(method), ".twv")).string();
    row.bytes = encode_ours(c, method, target_bpp, stream, row);
    decode_ours(c, stream, row, shown);
    std::error_code ec;
    fs::remove(stream, ec);
    row.total_s = row.encode_s + row.decode_s;
    finish_row(row, *c.clip);
    return row;
}

struct PeerRun {
    VideoRow row;
    Image shown;
};

// One encode and decode through libav. The time of reading the clip and measuring (in the
// callbacks) is taken off the total, so total_s is the codec's.
PeerRun run_peer_once(const RunContext& c, VideoMethod method, double target_bpp,
                      const PeerVideoOptions& o, const std::function<void(double)>& progress) {
    const ClipInfo& clip = *c.clip;
    PeerRun run{start_row(c, method, target_bpp), {}};
    FrameSource input(clip.path, c.source), reference(clip.path, c.source);
    QualityMeter meter;
    Image frame;
    int64_t sent = 0;
    double outside = 0;
    auto next_frame = [&](Image& out) {
        const auto start = Clock::now();
        const bool more = sent < clip.frames && input.read(out);
        sent += more;
        outside += seconds_since(start);
        return more;
    };
    auto on_decoded = [&](int index, const Image& decoded) {
        const auto start = Clock::now();
        if (!reference.read(frame)) throw Error(str(clip.path, ": the clip got shorter"));
        meter.add(frame, decoded);
        if (index == clip.shown_frame) run.shown = decoded;
        progress(static_cast<double>(index + 1) / clip.frames);
        outside += seconds_since(start);
    };
    const auto start = Clock::now();
    const PeerVideoResult result = encode_peer_video(next_frame, on_decoded, o);
    run.row.total_s = seconds_since(start) - outside;
    run.row.bytes = result.bytes;
    meter.fill(run.row);
    finish_row(run.row, clip);
    return run;
}

// A peer's only quality knob as a number x that the stream's size falls with: snow's
// log(qscale), x264's CRF. The search starts at `start` and steps by `step` until it brackets
// the target.
struct QualityKnob {
    const char* name;
    double lo, hi, start, step;
    bool logarithmic;  // quality = exp(x)
};

// Snow: qscale 0.1 to 255 (its range), from 4 in steps of 4x; x264: CRF 0 to 51, from 26 in
// steps of 8 (about a factor 2.5 in rate).
const QualityKnob kSnowKnob{"qscale",      std::log(0.1), std::log(255.0),
                            std::log(4.0), std::log(4.0), true};
const QualityKnob kX264Knob{"crf", 0, 51, 26, 8, false};
constexpr int kMaxTries = 8;
constexpr double kTolerance = 0.05;  // bytes within 5 % of the target end the search

// The next x: inside a bracket, the secant on log(bytes) kept off the bracket's ends; outside,
// a step towards the target.
double next_knob(const QualityKnob& k, double x, double error,
                 const std::optional<std::pair<double, double>>& over,
                 const std::optional<std::pair<double, double>>& under) {
    if (over && under) {
        const auto [xa, ea] = *over;  // too many bytes: x too low
        const auto [xb, eb] = *under;
        const double t = std::clamp(ea / (ea - eb), 0.1, 0.9);
        return xa + t * (xb - xa);
    }
    return std::clamp(error > 0 ? x + k.step : x - k.step, k.lo, k.hi);
}

// Searches the knob for the size nearest the target (within kTolerance, at most kMaxTries
// encodes) and returns that run. A try the peer fails (Snow's own decoder refuses some of its
// streams at the coarsest qscales) is not the end: the search backs off halfway towards the last
// good setting (or the start) and stays on that side; only when no try succeeds does the error
// come through.
PeerRun search_quality(const RunContext& c, VideoMethod method, double target_bpp,
                       PeerVideoOptions o, const QualityKnob& k) {
    const double target_bytes = target_bpp * c.clip->pixels() / 8;
    std::optional<std::pair<double, double>> over, under;
    std::optional<double> failed;  // a knob value the peer failed at
    std::string failure;
    PeerRun best;
    double best_error = INFINITY, best_x = k.start, x = k.start;
    for (int i = 0; i < kMaxTries; ++i) {
        o.quality = k.logarithmic ? std::exp(x) : x;
        PeerRun run;
        try {
            run = run_peer_once(c, method, target_bpp, o, [&](double f) {
                c.progress((i + f) / kMaxTries, str(k.name, " try ", i + 1).c_str());
            });
        } catch (const Error& e) {
            failure = e.what();
            failed = x;
            const double next = 0.5 * (x + (std::isfinite(best_error) ? best_x : k.start));
            if (std::abs(next - x) < 1e-3) break;
            x = next;
            continue;
        }
        const double error = std::log(run.row.bytes / target_bytes);
        if (std::abs(error) < best_error) {
            best_error = std::abs(error);
            best_x = x;
            best = std::move(run);
            best.row.setting = str(k.name, " ", std::lround(o.quality * 1000) / 1000.0);
        }
        best.row.tries = i + 1;
        if (best_error <= std::log1p(kTolerance)) break;
        (error > 0 ? over : under) = std::make_pair(x, error);
        double next = next_knob(k, x, error, over, under);
        if (failed && (next - x) * (*failed - x) > 0 &&
            std::abs(next - x) >= std::abs(*failed - x)) {
            next = 0.5 * (x + *failed);  // not past a setting the peer failed at
        }
        if (std::abs(next - x) < 1e-3) break;  // at the end of the knob's range
        x = next;
    }
    if (!std::isfinite(best_error)) throw Error(failure);
    if (failed) {  // said in the row, as its failures are
        const double q = k.logarithmic ? std::exp(*failed) : *failed;
        best.row.setting += str(" (", k.name, " ", std::lround(q * 1000) / 1000.0, " failed)");
    }
    return best;
}

PeerCodec peer_codec(VideoMethod m) {
    return m == VideoMethod::snow  ? PeerCodec::snow
           : m == VideoMethod::vc2 ? PeerCodec::vc2
                                   : PeerCodec::x264;
}

VideoRow run_peer(const RunContext& c, VideoMethod method, double target_bpp, Image* shown) {
    const PeerVideoOptions o{
        .codec = peer_codec(method), .fps = c.clip->fps, .gop = c.group, .threads = 1};
    PeerRun run;
    if (method == VideoMethod::vc2) {
        PeerVideoOptions rate = o;
        rate.kbps = kbps_for(*c.clip, target_bpp);
        run = run_peer_once(c, method, target_bpp, rate, [&](double f) { c.progress(f, "vc2"); });
        run.row.setting = str("kbps ", std::lround(rate.kbps * 100) / 100.0);
    } else {
        run = search_quality(c, method, target_bpp, o,
                             method == VideoMethod::snow ? kSnowKnob : kX264Knob);
    }
    if (shown) *shown = std::move(run.shown);
    return run.row;
}

}  // namespace

double luma_psnr(const Image& reference, const Image& test) {
    double sum = 0;
    const size_t n = reference.planes[0].size();
    for (size_t i = 0; i < n; ++i) {
        double d = 0;
        constexpr double kWeights[3] = {0.299, 0.587, 0.114};
        for (int c = 0; c < 3; ++c) {
            d += kWeights[c] * (quantized(reference.planes[c][i]) - quantized(test.planes[c][i]));
        }
        sum += d * d;
    }
    return sum == 0 ? kMaxPsnr : std::min(kMaxPsnr, 10 * std::log10(255.0 * 255.0 * n / sum));
}

VideoRow run_video_method(const RunContext& context, VideoMethod method, double target_bpp,
                          Image* shown) {
    const bool ours = method == VideoMethod::moving_mesh || method == VideoMethod::static_mesh ||
                      method == VideoMethod::grid53 || method == VideoMethod::grid97;
    try {
        return ours ? run_ours(context, method, target_bpp, shown)
                    : run_peer(context, method, target_bpp, shown);
    } catch (const Error& e) {
        VideoRow row = start_row(context, method, target_bpp);
        row.error = e.what();
        row.tries = 0;
        return row;
    }
}

}  // namespace tesswave::eval
