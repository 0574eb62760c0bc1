#include "enc_video.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "core/codec/bitplane.h"
#include "core/codec/still_codec.h"
#include "core/io/file_io.h"
#include "core/math/colour.h"
#include "core/math/error.h"
#include "core/math/metrics.h"
#include "core/math/sampling.h"
#include "core/math/strings.h"
#include "core/math/validate.h"
#include "mesh_motion.h"

namespace tesswave::video {
namespace {

void fps_fraction(double fps, TwvHeader& h) {
    if (!(fps > 0) || fps > 1000) throw Error(str("frame rate ", fps, " is out of range"));
    const int64_t den = std::abs(fps - std::round(fps)) < 1e-9 ? 1 : 1001;
    const int64_t num = std::llround(fps * static_cast<double>(den));
    const int64_t g = std::gcd(num, den);
    h.fps_num = static_cast<int>(num / g);
    h.fps_den = static_cast<int>(den / g);
}

TwvGroup choose_group(const TwvHeader& h, const VideoEncodeOptions& o) {
    TwvGroup g;
    g.transform = o.transform;
    g.channel_factors = ycbcr_step_factors(h.channels);
    if (o.transform != TwiTransform::mesh) {
        const int fit = static_cast<int>(std::floor(std::log2(std::min(h.width, h.height))));
        g.levels = std::clamp(o.levels > 0 ? o.levels : 5, 0, std::max(fit, 0));
        return g;
    }
    if (!(o.density > 0) || o.density > 16) {
        throw Error(str("density ", o.density, " must lie in (0, 16] samples per pixel"));
    }
    const DefaultGrid grid =
        default_grid(h.width, h.height, o.density, o.levels > 0 ? std::min(o.levels, 12) : 0);
    const int J = grid.levels;
    if (o.motion_level < 0 || o.motion_level > J) {
        throw Error(str("motion level ", o.motion_level, " must lie in [0, ", J, "]"));
    }
    const int k = o.motion_level;
    g.grid_cols = grid.cols << k;
    g.grid_rows = grid.rows << k;
    g.grid_cols = std::min(g.grid_cols, h.width);
    g.grid_rows = std::min(g.grid_rows, h.height);
    g.levels = J - k;
    g.motion = o.motion;
    g.mesh_wavelet = o.mesh_wavelet;
    const std::string problem = twv_group_size_problem(g, h);
    if (!problem.empty()) throw Error(problem + "; lower --levels or --density");
    return g;
}

// Whether band b is one of the finest detail bands: the last mesh step's edge and face points,
// or the grid's level-1 detail.
bool finest_band(const CodingLayout& layout, const CodingBand& b) {
    if (b.type == 'e' || b.type == 'f') {
        int finest = -1;
        for (const CodingBand& other : layout.bands) finest = std::max(finest, other.level);
        return b.level == finest;
    }
    return b.level == 1 && b.type != 'L';
}

}  // namespace

VideoEncoder::VideoEncoder(const std::string& path, int width, int height, double fps,
                           const VideoEncodeOptions& o)
    : path_(path), options_(o) {
    if (width < 1 || height < 1 || width > 16384 || height > 16384 ||
        int64_t{width} * height > TwvLimits{}.max_pixels) {
        throw Error(str("cannot code ", width, "x", height, " frames"));
    }
    if (!(o.kbps >= 0) || !std::isfinite(o.kbps) || !std::isfinite(o.quality)) {
        throw Error(str("rate ", o.kbps, " kbps must be a positive number (or 0 for a quality)"));
    }
    if (o.kbps == 0 && (o.quality < 10 || o.quality > 80)) {
        throw Error(str("quality ", o.quality, " dB must lie in [10, 80]"));
    }
    if (o.group < 1) throw Error(str("group length ", o.group, " must be at least 1"));
    if (!(o.intra_weight >= 1) || o.intra_weight > 100) {
        throw Error(str("intra weight ", o.intra_weight, " must lie in [1, 100]"));
    }
    if (!(o.repeat_psnr >= 0) || o.repeat_psnr > 200) {
        throw Error(str("repeat PSNR ", o.repeat_psnr, " dB must lie in [0, 200]"));
    }
    if (options_.kbps > 0) options_.quality = 0;  // one mode: the rate
    header_.width = width;
    header_.height = height;
    fps_fraction(fps, header_);
    group_ = choose_group(header_, o);
    domain_ = group_domain(header_, group_, true);
    group_length_ =
        o.low_delay ? o.group : std::min(o.group, twv_max_lifted_frames(group_, header_));
    for (const CodingBand& b : domain_->layout().bands) {
        group_.band_norms.push_back(static_cast<float>(b.norm));
    }
    if (domain_->is_mesh() && group_.motion == TwvMotion::tracked) {
        motion_ = std::make_unique<MeshMotion>(domain_->shape().mesh, o.mesh_motion);
    }
    if (domain_->is_mesh() && o.grid_groups && !o.low_delay) {
        VideoEncodeOptions grid = o;
        grid.transform = TwiTransform::grid97;
        grid.levels = 0;
        grid_group_ = choose_group(header_, grid);
        grid_domain_ = group_domain(header_, grid_group_, true);
        for (const CodingBand& b : grid_domain_->layout().bands) {
            grid_group_.band_norms.push_back(static_cast<float>(b.norm));
        }
    }
    temporary_ = temporary_name(path);
    out_.open(temporary_, std::ios::binary | std::ios::trunc);
    if (!out_) throw Error(str(path, ": cannot write"));
    write(write_twv_header(header_));
}

VideoEncoder::~VideoEncoder() {
    if (!finished_) {
        out_.close();
        discard_temporary(temporary_);
    }
}

void VideoEncoder::write(const std::vector<uint8_t>& bytes) {
    out_.write(reinterpret_cast<const char*>(bytes.data()),
               static_cast<std::streamsize>(bytes.size()));
    if (!out_) throw Error(str(path_, ": write failed"));
    written_ += bytes.size();
}

// A frame's share of the rate: a group of G frames gets G B bytes (B a frame), its intra frame
// w times a delta frame's d = G B / (w + G - 1).
double VideoEncoder::frame_share(bool intra) const {
    const double B = options_.kbps * 1000 / 8 / header_.fps();
    const double G = options_.group, w = options_.intra_weight;
    const double delta = G * B / (w + G - 1);
    return intra ? w * delta : delta;
}

// The frame's byte budget. The plan after t frames, k of them in the current group, is
// t B + (w + k - 1) d - k B (the group's front-loaded intra, repaid by G). Bytes spent beyond the
// plan (a group cut short by a tracking failure, the file header) are repaid a quarter per frame;
// bytes left unspent go to the next frame.
int64_t VideoEncoder::frame_budget(bool intra, uint64_t spent) const {
    const double B = options_.kbps * 1000 / 8 / header_.fps();
    const double k = intra ? 0 : static_cast<double>(in_group_);
    const double front = k > 0 ? frame_share(true) + (k - 1) * frame_share(false) - k * B : 0;
    const double debt = static_cast<double>(spent) - (static_cast<double>(frames_) * B + front);
    const double share = frame_share(intra);
    const double budget = share - (debt > 0 ? 0.25 * debt : debt);
    return static_cast<int64_t>(std::floor(std::max(budget, 0.25 * share)));
}

// The coefficients a fully decoded frame holds when `x` is quantized with `base_step`.
Planes VideoEncoder::requantized(const CodingDomain& domain, const Planes& x,
                                 float base_step) const {
    // Every plane known: the decoder's reconstruction of a fully decoded frame (as
    // quantize_planes, then dequantize; in one pass).
    const CodingLayout& layout = domain.layout();
    Planes y = domain.zeros();
    for (size_t c = 0; c < y.size(); ++c) {
        requantize(layout, x[c], domain.band_steps(static_cast<int>(c), base_step), y[c]);
        if (!options_.chroma_420 || c == 0 || c > 2) continue;
        for (const CodingBand& b : layout.bands) {
            if (!finest_band(layout, b)) continue;
            for (int32_t k = b.begin; k < b.end; ++k) y[c][layout.order[k]] = 0.0f;
        }
    }
    return y;
}

// The base step at which `psnr_at` (a falling function of the step) reaches the target PSNR:
// false position on log2 of the step (Illinois: a side that stays put has its value halved), as
// the PSNR falls nearly linearly in it (about 6 dB a doubling), until the PSNR is within
// 0.02 dB above the target or the bracket is 0.01 wide: 5 to 8 evaluations (the two ends
// included; carphone and aerial) where bisection took 12. A target above what the finest step
// reaches (the mesh's resampling caps the quality) is lowered to 0.25 dB below that ceiling, so
// that the rate stays finite; the result says which target was used.
VideoEncoder::QualityStep VideoEncoder::step_for_quality(
    const std::function<double(float)>& psnr_at) const {
    double lo = -14, hi = 0;  // log2 of the step: the PSNR meets the target at lo, not at hi
    const double ceiling = psnr_at(static_cast<float>(std::exp2(lo)));
    const double target = std::min(options_.quality, ceiling - 0.25);
    // f_lo and f_hi weigh the next guess (Illinois halves them); above is what lo measured.
    double above = ceiling - target, f_lo = above, f_hi = psnr_at(1.0f) - target;
    if (f_hi >= 0) return {1.0f, target};
    int kept = 0;  // +1: lo moved last, -1: hi moved last
    for (int i = 0; i < 16 && hi - lo > 0.01 && above >= 0.02; ++i) {
        // The interpolated crossing, kept off the ends so that the bracket always shrinks.
        const double w = hi - lo;
        const double mid = std::clamp(hi - f_hi * w / (f_hi - f_lo), lo + 0.001 * w + 0.001,
                                      hi - 0.001 * w - 0.001);
        const double f = psnr_at(static_cast<float>(std::exp2(mid))) - target;
        if (!std::isfinite(f)) break;  // lo still meets the target
        if (f >= 0) {
            lo = mid;
            f_lo = above = f;
            if (kept == 1) f_hi *= 0.5;
            kept = 1;
        } else {
            hi = mid;
            f_hi = f;
            if (kept == -1) f_lo *= 0.5;
            kept = -1;
        }
    }
    return {static_cast<float>(std::exp2(lo)), target};
}

// Low delay: the base step whose intra image reaches the target PSNR.
float VideoEncoder::calibrate_step(const Image& frame) {
    Planes x;
    domain_->analyze(frame, vertices_, x, options_.sampling, options_.projection);
    Image image;
    const QualityStep q = step_for_quality([&](float step) {
        domain_->synthesize(requantized(*domain_, x, step), vertices_, image);
        return psnr(frame, image).all;
    });
    quality_target_ = q.target;
    return q.step;
}

// Dead-zone quantization of every channel with the group's steps; with 4:2:0 chroma, the finest
// detail of Cb and Cr is left out.
IntPlanes VideoEncoder::quantize_planes(const CodingDomain& domain, const Planes& r,
                                        float base_step) const {
    const CodingLayout& layout = domain.layout();
    IntPlanes q(r.size(), std::vector<int32_t>(domain.size(), 0));
    for (size_t c = 0; c < r.size(); ++c) {
        quantize(layout, r[c], domain.band_steps(static_cast<int>(c), base_step), q[c]);
        if (!options_.chroma_420 || c == 0 || c > 2) continue;
        for (const CodingBand& b : layout.bands) {
            if (!finest_band(layout, b)) continue;
            for (int32_t k = b.begin; k < b.end; ++k) q[c][layout.order[k]] = 0;
        }
    }
    return q;
}

void VideoEncoder::start_group(int64_t number) {
    group_.first_frame = number;
    index_.group_offsets.push_back(written_);
    index_.group_first.push_back(number);
    largest_group_samples_ = std::max(largest_group_samples_, twv_group_samples(group_));
    write(twv_chunk('G', write_twv_group(group_)));
}

std::vector<uint8_t> VideoEncoder::code_frame(const Image& frame, TwvFrame& f, int64_t budget) {
    domain_->analyze(frame, vertices_, residual_, options_.sampling, options_.projection);
    if (f.kind == TwvFrameKind::intra) coefficients_ = domain_->zeros();
    for (size_t c = 0; c < residual_.size(); ++c) {
        for (size_t i = 0; i < residual_[c].size(); ++i) residual_[c][i] -= coefficients_[c][i];
    }
    const IntPlanes q = quantize_planes(*domain_, residual_, f.base_step);
    f.planes = count_planes(domain_->layout(), const_spans(q));
    BitplaneOptions bo = twv_stream_options(domain_->layout(), header_.version);
    if (budget >= 0) {
        const int64_t overhead =
            static_cast<int64_t>(twv_chunk('F', write_twv_frame(f, group_)).size());
        bo.max_bytes = static_cast<size_t>(std::max<int64_t>(budget - overhead, 1));
    }
    bool empty = true;
    for (const auto& channel : f.planes) {
        for (uint8_t p : channel) empty = empty && p == 0;
    }
    if (!empty) f.stream = encode_bitplanes(domain_->layout(), const_spans(q), f.planes, bo);
    add_decoded_residual(*domain_, f, coefficients_, header_.version);
    domain_->synthesize(coefficients_, vertices_, reconstruction_);
    return twv_chunk('F', write_twv_frame(f, group_));
}

bool VideoEncoder::take_repeat(const Image& frame) {
    // A repeat is shown, so it counts towards the group's length (and the frames held).
    if (options_.low_delay || options_.repeat_psnr <= 0 || pending_.empty() ||
        in_group_ >= group_length_) {
        return false;
    }
    const double threshold =
        std::max(options_.repeat_psnr, options_.quality > 0 ? options_.quality + 6 : 0.0);
    Pending& last = pending_.back();
    if (psnr(frame, last.frame).all < threshold) return false;
    EncodedFrame info;
    info.number = frames_;
    info.repeat = true;
    last.repeats.push_back({frame, std::move(info)});
    ++frames_;
    ++in_group_;
    return true;
}

int64_t VideoEncoder::pending_shown() const {
    int64_t shown = 0;
    for (const Pending& p : pending_) shown += 1 + static_cast<int64_t>(p.repeats.size());
    return shown;
}

std::vector<EncodedFrame> VideoEncoder::encode(const Image& frame) {
    if (finished_) throw Error("the encoder has finished");
    if (frame.width != header_.width || frame.height != header_.height) {
        throw Error(str("frame ", frames_, " is ", frame.width, "x", frame.height, ", the clip is ",
                        header_.width, "x", header_.height));
    }
    if (take_repeat(frame)) {
        if (in_group_ < group_length_) return {};
        return code_pending(motion_ != nullptr);  // a full group (tracked: as after a frame)
    }
    EncodedFrame info;
    info.number = frames_;
    const Progress& progress = options_.progress;
    if (motion_) {
        report(progress, 0.0, "tracking");
        motion_->track(frame);
        if (!options_.low_delay) return encode_lifted_tracked(frame, std::move(info));
    }
    const Mesh* rest = domain_->is_mesh() ? &domain_->shape().mesh : nullptr;
    bool intra = frames_ == 0 || in_group_ >= group_length_;
    std::vector<Vec2> v;
    if (!intra && motion_) {
        const std::vector<Vec2> expected = expected_positions(
            *rest, vertices_,
            in_group_ >= 2 ? std::span<const Vec2>(previous_) : std::span<const Vec2>());
        report(progress, 0.2, "fitting the mesh");
        const MotionStep step = motion_->fit(expected);
        info.tracks = step.tracks;
        info.fit_rms = step.rms;
        if (auto next = step_positions(*rest, step, vertices_, info.new_group))
            v = std::move(*next);
        intra = !info.new_group.empty();
    }
    std::vector<EncodedFrame> done;
    if (intra && !pending_.empty()) done = code_pending();
    // Groups start at the rest mesh.
    if (intra || (rest && !motion_)) {
        v = rest ? rest->vertices : std::vector<Vec2>{};
    }
    const uint64_t start = written_;
    std::vector<uint8_t> motion_bytes;
    if (motion_) {
        const bool two_back = !intra && in_group_ >= 2;
        const std::vector<Vec2>& from = intra ? rest->vertices : vertices_;
        if (v != from) {  // no bytes for a mesh that stays put
            motion_bytes = encode_motion(
                *rest, v, from,
                two_back ? std::span<const Vec2>(previous_) : std::span<const Vec2>());
        }
        motion_->pin(v, intra);
    }
    previous_ = std::move(vertices_);
    vertices_ = std::move(v);
    if (intra && options_.quality > 0 && options_.low_delay) {
        report(progress, 0.3, "calibrating");
        base_step_ = calibrate_step(frame);
    }
    info.quality_target = options_.quality > 0 ? quality_target_ : 0;
    if (rest) {
        info.mesh = std::shared_ptr<const Mesh>(domain_, rest);
        info.vertices = vertices_;
    }
    if (motion_) info.live_tracks = motion_->tracks();
    if (options_.low_delay) {
        info.motion_bytes = static_cast<int64_t>(motion_bytes.size());
        if (intra) start_group(frames_);
        TwvFrame f;
        f.number = frames_;
        f.kind = intra ? TwvFrameKind::intra : TwvFrameKind::delta;
        f.motion = std::move(motion_bytes);
        done.push_back(encode_low_delay(frame, std::move(info), f, start));
        return done;
    }
    report(progress, 0.5, "sampling");
    Pending p{.frame = frame,
              .coefficients = {},
              .vertices = vertices_,
              .motion = std::move(motion_bytes),
              .info = {}};
    domain_->analyze(frame, vertices_, p.coefficients, options_.sampling, options_.projection);
    p.info = std::move(info);
    pending_.push_back(std::move(p));
    in_group_ = intra ? 1 : in_group_ + 1;
    ++frames_;
    if (in_group_ >= group_length_) {
        for (EncodedFrame& e : code_pending()) done.push_back(std::move(e));
    }
    return done;
}

EncodedFrame VideoEncoder::encode_low_delay(const Image& frame, EncodedFrame info, TwvFrame& f,
                                            uint64_t start) {
    const bool intra = f.kind == TwvFrameKind::intra;
    f.base_step = options_.kbps > 0 ? 1.0f / 1024 : base_step_;
    int64_t budget = -1;
    if (options_.kbps > 0) {
        budget =
            frame_budget(intra, start) - static_cast<int64_t>(written_ - start);  // less the group
        const int64_t floor_bytes =
            static_cast<int64_t>(twv_chunk('F', write_twv_frame(f, group_)).size()) + 8;
        if (frames_ == 0 && budget < floor_bytes) {
            throw Error(str(options_.kbps, " kbps leaves ", budget,
                            " bytes for the first frame; it needs at least ", floor_bytes));
        }
    }
    report(options_.progress, 0.5, "coding");
    const std::vector<uint8_t> chunk = code_frame(frame, f, budget);
    index_.frame_offsets.push_back(written_);
    write(chunk);
    info.kind = f.kind;
    info.first_in_group = intra;
    info.bytes = static_cast<int64_t>(written_ - start);
    info.motion_bytes = static_cast<int64_t>(f.motion.size());
    info.psnr = psnr(frame, reconstruction_).all;
    info.reconstruction = reconstruction_;
    in_group_ = intra ? 1 : in_group_ + 1;
    ++frames_;
    coded_frames_ = frames_;
    return info;
}

std::vector<EncodedFrame> VideoEncoder::flush() {
    if (finished_) throw Error("the encoder has finished");
    return code_pending();
}

int64_t VideoEncoder::finish() {
    if (finished_) throw Error("the encoder has finished");
    if (frames_ == 0) throw Error(str(path_, ": no frames to write"));
    flush();
    // A clip that codes to very few bytes (flat or still content) would claim more decoding work
    // than its size lets a decoder grant (TwvLimits), so it gets a padding chunk of zeros, the
    // fewest bytes that make the file decodable within the default limits.
    const std::vector<uint8_t> index = twv_chunk('I', write_twv_index(index_));
    const int64_t needed =
        twv_file_bytes_needed(int64_t{header_.width} * header_.height, coded_frames_,
                              largest_group_bytes_, largest_group_samples_);
    if (needed == std::numeric_limits<int64_t>::max()) {
        throw Error(
            str(path_, ": a group of ", largest_group_bytes_,
                " bytes of coefficients is beyond the limits (shorten the groups with -g)"));
    }
    const int64_t short_by =
        needed - static_cast<int64_t>(written_ + index.size()) - kTwvTrailerBytes;
    const uint64_t index_start = written_;
    if (short_by > 0) {
        for (const std::vector<uint8_t>& chunk : twv_padding(short_by)) write(chunk);
        padding_ = static_cast<int64_t>(written_) - static_cast<int64_t>(index_start);
    }
    const uint64_t index_offset = written_;
    write(index);
    write(twv_trailer(index_offset));
    out_.close();
    if (!out_) throw Error(str(path_, ": write failed"));
    commit_temporary(temporary_, path_);
    finished_ = true;
    return static_cast<int64_t>(written_);
}

}  // namespace tesswave::video
