// The encoder's tracked lifted groups (enc_video.h): frames are tracked as they come, and a group
// is fitted and analysed when it is complete, on a canvas that covers every frame's view when the
// camera pans.
//
// A frame's offset is the camera's motion since the group's first frame: the sum of the median
// steps of the tracks carried from frame to frame (median_step). The canvas extends the frame by
// the span of the offsets (held within half the frame a side, rounded up to 8 pixels), with T0's
// grid over it at the frame's cell size; each frame is a window on it at its offset. The mesh is
// fitted on the canvas, so that it follows the pan by moving the window, not by stretching the
// cells at the border where new content enters (aerial, a 30-pixel pan in 16 frames: the top row of
// cells grew 1.6x and the bottom ones shrank to half). Samples a frame does not see take their
// value from the nearest frame that does, so that they add nothing to the temporal detail.
// Such a group is fitted and coded on the frame as well, and the better coding kept: a handheld
// camera's shake of a pixel or two (carphone) cost 0.3 to 0.5 dB on a canvas.
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/math/error.h"
#include "core/math/hierarchy.h"
#include "core/math/parallel.h"
#include "core/math/validate.h"
#include "enc_video.h"
#include "mesh_motion.h"

namespace tesswave::video {
namespace {

constexpr int kCanvasStep = 8;          // pixels: extensions are multiples of it (domains repeat)
constexpr double kMostExtension = 0.5;  // of the frame a side

// Samples of frame t outside the frame (by more than a pixel) take the value they have in the
// nearest frame that sees them (the earlier one on a tie); those no frame sees take frame 0's.
void fill_unseen(const Hierarchy& h, std::span<const std::vector<Vec2>> vertices, int width,
                 int height, std::span<Planes> samples) {
    const size_t n = samples.size();
    const int J = h.finest();
    std::vector<std::vector<uint8_t>> seen(n);
    for (size_t t = 0; t < n; ++t) {
        const std::vector<Vec2> p = refine_positions(h, vertices[t], J);
        seen[t].resize(p.size());
        for (size_t k = 0; k < p.size(); ++k) {
            seen[t][k] =
                p[k].x >= -1 && p[k].y >= -1 && p[k].x <= width + 1.0 && p[k].y <= height + 1.0;
        }
    }
    const size_t count = seen.empty() ? 0 : seen[0].size();
    std::vector<int> last(n), next(n);
    for (size_t k = 0; k < count; ++k) {
        int at = -1;
        for (size_t t = 0; t < n; ++t) {
            if (seen[t][k]) at = static_cast<int>(t);
            last[t] = at;
        }
        if (at < 0) {  // never seen: one value for the whole group
            for (size_t t = 1; t < n; ++t) {
                for (size_t c = 0; c < samples[t].size(); ++c) samples[t][c][k] = samples[0][c][k];
            }
            continue;
        }
        at = -1;
        for (size_t t = n; t-- > 0;) {
            if (seen[t][k]) at = static_cast<int>(t);
            next[t] = at;
        }
        for (size_t t = 0; t < n; ++t) {
            if (seen[t][k]) continue;
            const int i = static_cast<int>(t);
            const int from =
                next[t] < 0 || (last[t] >= 0 && i - last[t] <= next[t] - i) ? last[t] : next[t];
            for (size_t c = 0; c < samples[t].size(); ++c) {
                samples[t][c][k] = samples[static_cast<size_t>(from)][c][k];
            }
        }
    }
}

// The least and largest offsets, x and y apart.
struct OffsetSpan {
    double lo[2] = {std::numeric_limits<double>::infinity(),
                    std::numeric_limits<double>::infinity()};
    double hi[2] = {-lo[0], -lo[1]};
    void add(Vec2 o) {
        lo[0] = std::min(lo[0], o.x), hi[0] = std::max(hi[0], o.x);
        lo[1] = std::min(lo[1], o.y), hi[1] = std::max(hi[1], o.y);
    }
};

}  // namespace

std::vector<EncodedFrame> VideoEncoder::encode_lifted_tracked(const Image& frame,
                                                              EncodedFrame info) {
    // A group starts with the clip, after a full group or a flush, or at a cut.
    bool intra = pending_.empty() || in_group_ >= group_length_;
    if (!intra) {
        info.new_group = motion_->cut();
        intra = !info.new_group.empty();
    }
    Vec2 offset{};
    if (!intra) {
        // The content moved by the tracks' step, so the camera by its opposite; the span of a
        // group's offsets is held within the largest canvas.
        offset = pending_.back().offset - median_step(motion_->tracks());
        OffsetSpan span;
        span.add(offset);
        for (const Pending& p : pending_) span.add(p.offset);
        const double most_x = kMostExtension * header_.width;
        const double most_y = kMostExtension * header_.height;
        offset.x = std::clamp(offset.x, span.hi[0] - most_x, span.lo[0] + most_x);
        offset.y = std::clamp(offset.y, span.hi[1] - most_y, span.lo[1] + most_y);
    }
    std::vector<EncodedFrame> done;
    if (intra && !pending_.empty()) done = code_pending(false);
    pending_.push_back({.frame = frame,
                        .coefficients = {},
                        .vertices = {},
                        .motion = {},
                        .info = std::move(info),
                        .tracks = motion_->tracks(),
                        .offset = offset});
    in_group_ = intra ? 1 : in_group_ + 1;
    ++frames_;
    if (in_group_ >= group_length_) {
        for (EncodedFrame& e : code_pending(true)) done.push_back(std::move(e));
    }
    return done;
}

// The canvas the pending frames' offsets need, and each frame's window on it; the frame itself
// when they need none.
VideoEncoder::Canvas VideoEncoder::place_canvas() const {
    Canvas c{group_, domain_};
    OffsetSpan offsets;
    for (const Pending& p : pending_) offsets.add(p.offset);
    const double* lo = offsets.lo;
    const double* hi = offsets.hi;
    const int size[2] = {header_.width, header_.height};
    int extend[2] = {0, 0};
    for (int a = 0; a < 2; ++a) {
        const double span = hi[a] - lo[a];
        if (span >= 1) {
            extend[a] =
                std::min(kCanvasStep * static_cast<int>(std::ceil(span / kCanvasStep)), size[a]);
        }
    }
    if (!options_.canvas || (extend[0] == 0 && extend[1] == 0)) return c;
    TwvGroup g = group_;
    g.extend_x = extend[0];
    g.extend_y = extend[1];
    // Cells of the frame's size, as near as a whole count gives.
    const auto cells = [](int count, int pixels, int extended) {
        const long wanted = std::lround(static_cast<double>(count) * extended / pixels);
        return static_cast<int>(std::clamp<long>(wanted, count, extended));
    };
    g.grid_cols = cells(group_.grid_cols, size[0], size[0] + extend[0]);
    g.grid_rows = cells(group_.grid_rows, size[1], size[1] + extend[1]);
    g.lifted = static_cast<int>(pending_.size());
    if (!twv_group_size_problem(g, header_).empty()) return c;  // the frame's domain will do
    g.lifted = 0;
    g.band_norms.clear();
    c.domain = group_domain(header_, g, true);
    for (const CodingBand& b : c.domain->layout().bands) {
        g.band_norms.push_back(static_cast<float>(b.norm));
    }
    c.group = std::move(g);
    // The offsets centred in the canvas, on the motion grid.
    for (const Pending& p : pending_) {
        const double o[2] = {p.offset.x, p.offset.y};
        Window w;
        for (int a = 0; a < 2; ++a) {
            const double at = o[a] - lo[a] + 0.5 * (extend[a] - (hi[a] - lo[a]));
            w[a] = static_cast<int32_t>(
                std::clamp<long>(std::lround(at * kMotionUnit), 0, long{extend[a]} * 4));
        }
        c.windows.push_back(w);
    }
    return c;
}

// Fits the mesh on the canvas frame by frame, up to a fit that fails (the group ends there).
VideoEncoder::GroupFrames VideoEncoder::fit_group(Canvas canvas) const {
    GroupFrames out{.canvas = std::move(canvas)};
    const Mesh& rest = out.canvas.domain->shape().mesh;
    const std::vector<Window>& windows = out.canvas.windows;
    MeshPins pins(rest, options_.mesh_motion);
    std::vector<Vec2> v, before;  // the frame before's positions, and the one before that
    for (size_t t = 0; t < pending_.size(); ++t) {
        const Pending& p = pending_[t];
        const Vec2 window = windows.empty() ? Vec2{} : window_offset(windows[t][0], windows[t][1]);
        std::vector<Vec2> next;
        int tracks = 0;
        double rms = 0;
        if (t == 0) {
            next = rest.vertices;
        } else {
            const std::vector<Vec2> expected = expected_positions(
                rest, v, t >= 2 ? std::span<const Vec2>(before) : std::span<const Vec2>());
            const MotionStep step = pins.fit(p.tracks, expected, window);
            tracks = step.tracks;
            rms = step.rms;
            auto positions = step_positions(rest, step, v, out.failure);
            if (!positions) break;
            next = std::move(*positions);
        }
        const std::vector<Vec2>& from = t == 0 ? rest.vertices : v;
        out.motion.emplace_back();
        if (next != from) {  // no bytes for a mesh that stays put
            out.motion.back() = encode_motion(
                rest, next, from, t >= 2 ? std::span<const Vec2>(before) : std::span<const Vec2>());
        }
        pins.pin(p.tracks, next, t == 0, window);
        before = std::move(v);
        v = std::move(next);
        out.vertices.push_back(v);
        for (Vec2& q : out.vertices.back()) q = q - window;
        out.tracks.push_back(tracks);
        out.rms.push_back(rms);
    }
    return out;
}

void VideoEncoder::sample_still(Pending& p) const {
    if (!p.still.empty()) return;
    domain_->sample(p.frame, domain_->shape().mesh.vertices, p.still, options_.sampling,
                    options_.projection);
}

// The coefficients of the frames at their positions.
void VideoEncoder::analyze_group(GroupFrames& m) const {
    report(options_.progress, 0.5, "sampling");
    const CodingDomain& domain = *m.canvas.domain;
    const size_t n = m.vertices.size();
    m.coefficients.assign(n, {});
    // A frame per core (a frame's own kernels split badly on small frames).
    const std::vector<Vec2>& rest = domain_->shape().mesh.vertices;
    parallel_for(static_cast<int64_t>(n), [&](int64_t begin, int64_t end) {
        for (auto t = static_cast<size_t>(begin); t < static_cast<size_t>(end); ++t) {
            const Pending& p = pending_[t];
            if (m.canvas.domain == domain_ && !p.still.empty() && m.vertices[t] == rest) {
                m.coefficients[t] = p.still;  // the mesh at rest: the static mesh's samples
            } else {
                domain.sample(p.frame, m.vertices[t], m.coefficients[t], options_.sampling,
                              options_.projection);
            }
        }
    });
    if (m.canvas.group.has_canvas()) {
        fill_unseen(*domain.hierarchy(), m.vertices, header_.width, header_.height, m.coefficients);
    }
    parallel_for(static_cast<int64_t>(n), [&](int64_t begin, int64_t end) {
        for (auto t = static_cast<size_t>(begin); t < static_cast<size_t>(end); ++t) {
            domain.analyze_samples(m.coefficients[t]);
        }
    });
}

std::vector<EncodedFrame> VideoEncoder::code_pending(bool keep_rest) {
    std::vector<EncodedFrame> done;
    while (!pending_.empty()) {
        std::vector<GroupFrames> meshes;
        size_t n = pending_.size();
        if (motion_ && !options_.low_delay) {
            // On a canvas when the camera pans, and then on the frame too (the better is kept).
            report(options_.progress, 0.2, "fitting the mesh");
            std::vector<Canvas> canvases = {place_canvas()};
            if (canvases[0].group.has_canvas()) canvases.push_back({group_, domain_});
            meshes.resize(canvases.size());
            // Beside the fits, which go frame after frame, the frames' samples on the static mesh
            // (the group's coding there, code_lifted_group), a few frames a task, so that no core
            // waits for the fits. A frame left for the next group keeps them.
            constexpr size_t kStillFrames = 4;
            std::vector<size_t> still;
            for (size_t t = 0; t < pending_.size(); ++t) {
                if (pending_[t].still.empty()) still.push_back(t);
            }
            const size_t fits = canvases.size();
            const size_t still_tasks = (still.size() + kStillFrames - 1) / kStillFrames;
            parallel_tasks(static_cast<int64_t>(fits + still_tasks), [&](int64_t k) {
                const auto i = static_cast<size_t>(k);
                if (i < fits) {
                    meshes[i] = fit_group(std::move(canvases[i]));
                    return;
                }
                const size_t first = (i - fits) * kStillFrames;
                for (size_t j = first; j < std::min(still.size(), first + kStillFrames); ++j)
                    sample_still(pending_[still[j]]);
            });
            // The group runs as far as a fit holds; a mesh whose fit failed sooner is left out.
            n = 0;
            for (const GroupFrames& m : meshes) n = std::max(n, m.vertices.size());
            std::erase_if(meshes, [&](const GroupFrames& m) { return m.vertices.size() < n; });
            if (n < pending_.size()) pending_[n].info.new_group = meshes.front().failure;
            for (GroupFrames& m : meshes) analyze_group(m);
        } else {
            GroupFrames m{.canvas = {group_, domain_}};
            for (Pending& p : pending_) {
                m.vertices.push_back(std::move(p.vertices));
                m.motion.push_back(std::move(p.motion));
                m.coefficients.push_back(std::move(p.coefficients));
            }
            meshes.push_back(std::move(m));
        }
        std::vector<Pending> later(
            std::make_move_iterator(pending_.begin() + static_cast<std::ptrdiff_t>(n)),
            std::make_move_iterator(pending_.end()));
        pending_.resize(n);
        for (EncodedFrame& e : code_lifted_group(std::move(meshes))) done.push_back(std::move(e));
        pending_ = std::move(later);
        // A full group whose fit failed before its end: the frames after the failure start the
        // next group, which runs on to a full length.
        if (keep_rest && !pending_.empty()) {
            in_group_ = pending_shown();
            break;
        }
    }
    return done;
}

}  // namespace tesswave::video
