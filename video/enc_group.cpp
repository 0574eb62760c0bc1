// The encoder's lifted groups (enc_video.h): temporal transform, embedded streams, one cut, and
// the choice between the tracked mesh, the static one and the fixed grid.
#include <algorithm>
#include <cmath>
#include <functional>
#include <optional>

#include "allocation.h"
#include "core/codec/bitplane.h"
#include "core/math/error.h"
#include "core/math/metrics.h"
#include "core/math/parallel.h"
#include "core/math/strings.h"
#include "enc_video.h"
#include "temporal.h"

namespace tesswave::video {
namespace {

bool any_capped(const EmbeddedStream& s) {
    return std::find(s.pass_ends.begin(), s.pass_ends.end(), SIZE_MAX) != s.pass_ends.end();
}

// Squared error summed over a frame's samples and channels.
double squared_error(const Image& a, const Image& b) {
    double sum = 0;
    for (size_t c = 0; c < a.planes.size(); ++c) {
        for (size_t i = 0; i < a.planes[c].size(); ++i) {
            const double d = double{a.planes[c][i]} - b.planes[c][i];
            sum += d * d;
        }
    }
    return sum;
}

}  // namespace

// One way of coding the pending group: the frames' coefficients on `vertices` (their own, or the
// rest mesh) with `motion` bytes each, lifted, coded and cut; with the decoder's images.
VideoEncoder::GroupCoding VideoEncoder::code_group(const CodingDomain& domain, const TwvGroup& base,
                                                   std::vector<Planes> x,
                                                   const std::vector<std::vector<Vec2>>& vertices,
                                                   const std::vector<std::vector<uint8_t>>& motion,
                                                   TwvMotion kind, float fine_step,
                                                   std::span<const Window> windows) const {
    const int n = static_cast<int>(x.size());
    const int64_t first = pending_.front().info.number;
    const int64_t shown = pending_shown();  // the group's frames and their repeats
    const TemporalTree tree = temporal_tree(header_);
    const int levels = temporal_levels(n, tree);
    temporal_forward(x, levels, tree);
    const std::vector<double> norms = temporal_norms(n, levels, tree);
    GroupCoding g;
    g.group = base;
    g.group.first_frame = first;
    g.group.lifted = n;
    g.group.motion = kind;
    const size_t group_bytes = twv_chunk('G', write_twv_group(g.group)).size();

    // What the group may spend: its frames' share of the rate, less what the file has spent
    // beyond the plan so far. The streams get what the chunks leave (found after the cut below).
    int64_t budget = -1;
    double group_target = 0;
    if (options_.kbps > 0) {
        const double B = options_.kbps * 1000 / 8 / header_.fps();
        const double debt = static_cast<double>(written_) - static_cast<double>(coded_frames_) * B;
        const double share = static_cast<double>(shown) * B;
        group_target = std::max(share - debt, 0.5 * share);
        budget = static_cast<int64_t>(group_target);
    }
    const auto group_size = [&] {
        size_t bytes = group_bytes;
        for (const TwvFrame& f : g.frames)
            bytes += twv_chunk('F', write_twv_frame(f, g.group)).size();
        return bytes;
    };

    std::vector<EmbeddedStream> streams;
    const auto code_at = [&](float base_step, size_t cap) {
        g.frames.assign(static_cast<size_t>(n), {});
        streams.assign(static_cast<size_t>(n), {});
        size_t whole = 0;
        bool capped = false;
        for (int t = 0; t < n; ++t) {
            TwvFrame& f = g.frames[static_cast<size_t>(t)];
            f.number = pending_[static_cast<size_t>(t)].info.number;
            f.repeats = static_cast<int64_t>(pending_[static_cast<size_t>(t)].repeats.size());
            f.kind = TwvFrameKind::band;
            f.base_step = static_cast<float>(base_step / norms[static_cast<size_t>(t)]);
            f.motion = motion[static_cast<size_t>(t)];
            if (!windows.empty()) {
                f.window_x = windows[static_cast<size_t>(t)][0];
                f.window_y = windows[static_cast<size_t>(t)][1];
            }
            const IntPlanes q = quantize_planes(domain, x[static_cast<size_t>(t)], f.base_step);
            f.planes = count_planes(domain.layout(), const_spans(q));
            EmbeddedStream& s = streams[static_cast<size_t>(t)];
            bool empty = true;
            for (const auto& channel : f.planes) {
                for (uint8_t p : channel) empty = empty && p == 0;
            }
            if (empty) continue;
            BitplaneOptions bo = twv_stream_options(domain.layout(), header_.version);
            bo.max_bytes = cap;
            bo.pass_ends = &s.pass_ends;
            f.stream = encode_bitplanes(domain.layout(), const_spans(q), f.planes, bo);
            s.size = f.stream.size();
            whole += s.size;
            capped = capped || any_capped(s);
        }
        return capped || budget < 0 || whole > static_cast<size_t>(budget);
    };

    if (budget < 0) {
        // --psnr: the step at which the group's mean PSNR reaches the target, measured on every
        // frame of the fully decoded group (a frame per core). Every fourth frame and the last
        // stood for the group on the dyadic tree; on the bisection tree those are its coarser
        // slots, and the group's mean came out 0.5 to 0.6 dB above the target.
        std::vector<Image> images(static_cast<size_t>(n));
        // The search renders the group 5 to 8 times on the same vertices: a moved mesh's plans
        // are made once (a tenth of a carphone encode went to making them again), within
        // kPlanBytes (about 9 bytes a pixel each).
        std::vector<std::optional<RenderPlan>> plans;
        constexpr int64_t kPlanBytes = int64_t{96} << 20;
        if (int64_t{9} * domain.shape().width * domain.shape().height * n <= kPlanBytes) {
            plans.resize(static_cast<size_t>(n));
            parallel_for(n, [&](int64_t begin, int64_t end) {
                for (auto t = static_cast<size_t>(begin); t < static_cast<size_t>(end); ++t)
                    plans[t] = domain.plan_for(vertices[t]);
            });
        }
        const QualityStep quality = step_for_quality([&](float base_step) {
            std::vector<Planes> y(static_cast<size_t>(n));
            for (int t = 0; t < n; ++t) {
                y[static_cast<size_t>(t)] =
                    requantized(domain, x[static_cast<size_t>(t)],
                                static_cast<float>(base_step / norms[static_cast<size_t>(t)]));
            }
            temporal_inverse(y, levels, tree);
            synthesize_frames(domain, y, vertices, images, plans);
            double sum = 0;
            for (size_t i = 0; i < images.size(); ++i) {
                sum += std::min(psnr(pending_[i].frame, images[i]).all, 100.0);
            }
            return sum / n;
        });
        g.quality_target = quality.target;
        code_at(quality.step, SIZE_MAX);
    } else {
        // Fine enough that the cut falls inside the streams; each stream is capped at the whole
        // budget, which no single band may exceed.
        const size_t cap = static_cast<size_t>(budget) + 64;
        budget = std::max<int64_t>(budget - static_cast<int64_t>(group_size()), 0);
        float step = fine_step;
        while (!code_at(step, cap) && step >= 0x1p-16f) step *= 0.25f;
        // The cut for the streams' share; each round corrects it by what the chunks around the
        // streams (plane counts of the slots left non-empty, size varints) really took.
        const std::vector<TwvFrame> whole = g.frames;
        double streams_budget = group_target;
        CutPoint cut;
        for (int round = 0; round < 6; ++round) {
            cut = allocate_cuts(streams, static_cast<size_t>(std::max(streams_budget, 0.0)));
            for (int t = 0; t < n; ++t) {
                const size_t i = static_cast<size_t>(t);
                TwvFrame& f = g.frames[i];
                f = whole[i];
                f.stream.resize(std::min(f.stream.size(), cut.bytes[i]));
                if (f.stream.empty()) {
                    for (auto& channel : f.planes) std::fill(channel.begin(), channel.end(), 0);
                }
            }
            const double error = group_target - static_cast<double>(group_size());
            bool all_whole = true;
            for (int t = 0; t < n; ++t) {
                const size_t i = static_cast<size_t>(t);
                all_whole = all_whole && g.frames[i].stream.size() == whole[i].stream.size();
            }
            if (error >= 0 && (error < 0.002 * group_target || all_whole)) break;
            if (error < 0 && streams_budget <= 0) break;  // the chunks alone exceed the target
            streams_budget = std::max(streams_budget + error, 0.0);
        }
        // Where the next group starts: one sweep below this cut. Coding finer costs time and
        // changes nothing above the cut (a dead-zone plane at step s is the plane below it at
        // 2 s), and a next cut that falls lower only repeats the coding at a quarter the step.
        g.next_fine_step =
            std::clamp(step * std::exp2(static_cast<float>(cut.sweep) - 1.0f), 0x1p-16f, 1.0f);
    }

    // The decoder's images.
    std::vector<Planes> y =
        decode_lifted_group(domain, g.frames, n, temporal_tree(header_), header_.version);
    g.images.resize(static_cast<size_t>(n));
    synthesize_frames(domain, y, vertices, g.images);
    for (int t = 0; t < n; ++t) {
        const size_t i = static_cast<size_t>(t);
        g.squared_error += squared_error(pending_[i].frame, g.images[i]);
    }
    g.bytes = group_size();
    return g;
}

std::vector<EncodedFrame> VideoEncoder::code_lifted_group(std::vector<GroupFrames> meshes) {
    const size_t n = pending_.size();
    report(options_.progress, 0.6, "coding the group");
    bool moved = false;
    for (const GroupFrames& m : meshes) {
        moved = moved || m.canvas.group.has_canvas();
        for (const auto& bytes : m.motion) moved = moved || !bytes.empty();
    }
    // Which of two codings of the group to keep: the lower error at the rate (with --psnr: the
    // smaller group at no lower quality).
    const auto better = [&](const GroupCoding& a, const GroupCoding& b) {
        return options_.kbps > 0 ? a.squared_error < b.squared_error
                                 : a.bytes < b.bytes && a.squared_error <= 1.02 * b.squared_error;
    };
    // The codings: on each of the meshes (tracked: on a canvas and on the frame); on the static
    // mesh, whose frames carry no motion (motion never hurts); on the fixed grid (nor does the
    // mesh). They are independent tasks, each taken by the next free core (its kernels serial
    // there), the cheapest (the grid's) last; the choice below is made in this order.
    std::vector<std::optional<GroupCoding>> on_mesh(meshes.size());
    std::optional<GroupCoding> still, grid;
    std::vector<std::function<void()>> codings;
    for (size_t k = 0; k < meshes.size(); ++k) {
        codings.push_back([&, k] {
            GroupFrames& m = meshes[k];
            on_mesh[k] =
                code_group(*m.canvas.domain, m.canvas.group, std::move(m.coefficients), m.vertices,
                           m.motion, group_.motion, fine_step_[0], m.canvas.windows);
        });
    }
    if (moved) {
        codings.push_back([&] {
            const std::vector<Vec2>& rest = domain_->shape().mesh.vertices;
            std::vector<Planes> frames(n);
            for (size_t t = 0; t < n; ++t) {
                sample_still(pending_[t]);
                frames[t] = std::move(pending_[t].still);
                domain_->analyze_samples(frames[t]);
            }
            still = code_group(
                *domain_, group_, std::move(frames), std::vector<std::vector<Vec2>>(n, rest),
                std::vector<std::vector<uint8_t>>(n), TwvMotion::none, fine_step_[0]);
        });
    }
    if (grid_domain_) {
        codings.push_back([&] {
            std::vector<Planes> pixels(n);
            for (size_t t = 0; t < n; ++t) {
                grid_domain_->analyze(pending_[t].frame, {}, pixels[t], Sampling::point, {});
            }
            grid = code_group(*grid_domain_, grid_group_, std::move(pixels),
                              std::vector<std::vector<Vec2>>(n),
                              std::vector<std::vector<uint8_t>>(n), TwvMotion::none, fine_step_[1]);
        });
    }
    parallel_tasks(static_cast<int64_t>(codings.size()),
                   [&](int64_t k) { codings[static_cast<size_t>(k)](); });
    size_t chosen = 0;
    for (size_t k = 1; k < meshes.size(); ++k) {
        if (better(*on_mesh[k], *on_mesh[chosen])) chosen = k;
    }
    GroupCoding g = std::move(*on_mesh[chosen]);
    std::shared_ptr<const CodingDomain> domain = meshes[chosen].canvas.domain;
    std::vector<std::vector<Vec2>> vertices = std::move(meshes[chosen].vertices);
    if (still && better(*still, g)) {
        g = std::move(*still);
        domain = domain_;
        vertices.assign(n, domain_->shape().mesh.vertices);
    }
    if (options_.kbps > 0) fine_step_[0] = g.next_fine_step;
    if (grid) {
        if (options_.kbps > 0) fine_step_[1] = grid->next_fine_step;
        if (better(*grid, g)) {
            g = std::move(*grid);
            domain.reset();
        }
    }
    for (size_t t = 0; t < n && !meshes[chosen].tracks.empty(); ++t) {
        pending_[t].info.tracks = meshes[chosen].tracks[t];
        pending_[t].info.fit_rms = meshes[chosen].rms[t];
    }

    index_.group_offsets.push_back(written_);
    index_.group_first.push_back(g.group.first_frame);
    largest_group_bytes_ = std::max(largest_group_bytes_, twv_lifted_group_bytes(g.group, header_));
    largest_group_samples_ = std::max(largest_group_samples_, twv_group_samples(g.group));
    uint64_t start = written_;
    write(twv_chunk('G', write_twv_group(g.group)));
    std::vector<EncodedFrame> done;
    for (size_t t = 0; t < n; ++t) {
        Pending& p = pending_[t];
        const TwvFrame& f = g.frames[t];
        const uint64_t chunk_at = written_;
        index_.frame_offsets.push_back(chunk_at);
        write(twv_chunk('F', write_twv_frame(f, g.group)));
        EncodedFrame e = std::move(p.info);
        e.kind = TwvFrameKind::band;
        e.first_in_group = t == 0;
        e.grid_group = g.group.transform != group_.transform;
        e.canvas_group = g.group.has_canvas();
        e.static_group = !e.grid_group && g.group.motion == TwvMotion::none &&
                         group_.motion == TwvMotion::tracked;
        e.bytes = static_cast<int64_t>(written_ - start);
        e.motion_bytes = static_cast<int64_t>(f.motion.size());
        e.psnr = psnr(p.frame, g.images[t]).all;
        e.quality_target = g.quality_target;
        e.reconstruction = std::move(g.images[t]);
        if (domain && domain->is_mesh()) {
            e.mesh = std::shared_ptr<const Mesh>(domain, &domain->shape().mesh);
            e.vertices = vertices[t];
        }
        e.live_tracks = std::move(p.tracks);
        coded_frames_ += 1 + static_cast<int64_t>(p.repeats.size());
        done.push_back(std::move(e));
        // Its repeats share its chunk and show its image.
        const size_t shown = done.size() - 1;
        for (Repeat& r : p.repeats) {
            index_.frame_offsets.push_back(chunk_at);
            const EncodedFrame& shown_frame = done[shown];
            EncodedFrame c = std::move(r.info);
            c.kind = shown_frame.kind;
            c.grid_group = shown_frame.grid_group;
            c.canvas_group = shown_frame.canvas_group;
            c.static_group = shown_frame.static_group;
            c.psnr = psnr(r.frame, shown_frame.reconstruction).all;
            c.quality_target = shown_frame.quality_target;
            c.reconstruction = shown_frame.reconstruction;
            c.mesh = shown_frame.mesh;
            c.vertices = shown_frame.vertices;
            done.push_back(std::move(c));
        }
        start = written_;
    }
    pending_.clear();
    return done;
}

}  // namespace tesswave::video
