#include "twv_domain.h"

#include <algorithm>
#include <numeric>

#include "core/codec/bitplane.h"
#include "core/math/error.h"
#include "core/math/grid_mesh.h"
#include "core/math/parallel.h"
#include "mesh_motion.h"
#include "temporal.h"

namespace tesswave::video {

std::shared_ptr<const CodingDomain> group_domain(const TwvHeader& header, const TwvGroup& group,
                                                 bool measure_norms) {
    if (!measure_norms && group.band_norms.empty()) {
        throw Error("group band count does not match its coding layout");
    }
    Mesh rest;
    if (group.transform == TwiTransform::mesh) {
        // Rest positions on the motion grid, so that a mesh that does not move codes no motion.
        rest = grid_mesh(header.width + group.extend_x, header.height + group.extend_y,
                         group.grid_cols, group.grid_rows);
        rest.vertices = round_to_motion_unit(rest.vertices);
    }
    DomainShape shape{.transform = group.transform,
                      .width = header.width,
                      .height = header.height,
                      .channels = header.channels,
                      .colour = header.channels == 3 ? TwiColour::ycbcr : TwiColour::none,
                      .levels = group.levels,
                      .mesh = std::move(rest),
                      .channel_factors = group.channel_factors,
                      .canvas = group.has_canvas(),
                      .mesh_wavelet = group.transform == TwiTransform::mesh ? group.mesh_wavelet
                                                                            : MeshWavelet::lifted,
                      .grid_cols = group.grid_cols,
                      .grid_rows = group.grid_rows};
    const int probes = measure_norms ? 1 : 0;
    const std::span<const float> norms =
        measure_norms ? std::span<const float>() : std::span<const float>(group.band_norms);
    // A canvas's size follows the camera, so it seldom repeats: it lives with its group, not in
    // the cache, whose few entries would otherwise fill with canvases (a 600-frame clip held 10 %
    // more memory than a 120-frame one).
    if (group.has_canvas()) return std::make_shared<const CodingDomain>(shape, probes, norms);
    return shared_domain(shape, probes, norms);
}

Vec2 window_offset(int32_t left, int32_t top) { return {left / kMotionUnit, top / kMotionUnit}; }

std::vector<Vec2> window_vertices(std::span<const Vec2> canvas, const TwvFrame& frame) {
    const Vec2 window = window_offset(frame.window_x, frame.window_y);
    std::vector<Vec2> out(canvas.begin(), canvas.end());
    for (Vec2& p : out) p = p - window;
    return out;
}

BitplaneOptions twv_stream_options(const CodingLayout& layout, int version) {
    return {.shifts = std::vector<int>(layout.bands.size(), 0),
            .fast_start = version >= 2,
            .blocks = version >= 6};
}

void add_decoded_residual(const CodingDomain& domain, const TwvFrame& frame, Planes& x,
                          int version) {
    const CodingLayout& layout = domain.layout();
    const BitplaneOptions options = twv_stream_options(layout, version);
    const DecodedPlanes d = decode_bitplanes(layout, frame.planes, frame.stream, options);
    std::vector<float> r(layout.size);
    for (size_t c = 0; c < x.size(); ++c) {
        const int channel = static_cast<int>(c);
        dequantize(layout, d, channel, domain.band_steps(channel, frame.base_step), false, r);
        for (int32_t i = 0; i < layout.size; ++i) x[c][i] += r[i];
    }
}

TemporalTree temporal_tree(const TwvHeader& header) {
    return header.version >= 4 ? TemporalTree::bisection : TemporalTree::dyadic;
}

std::vector<Planes> decode_lifted_group(const CodingDomain& domain, std::span<const TwvFrame> bands,
                                        int frames, TemporalTree tree, int version) {
    if (frames < 1 || bands.size() > static_cast<size_t>(frames)) {
        throw Error("lifted group: more bands than frames");
    }
    std::vector<Planes> x(static_cast<size_t>(frames), domain.zeros());
    // Each band's stream is its own: the cores decode a share of the frames each. The low band
    // is far larger than the high bands, so the shares are balanced by stream size (largest
    // first, each to the least loaded share); which core decodes a band changes nothing.
    const size_t shares =
        std::max<size_t>(1, std::min(static_cast<size_t>(thread_count()), bands.size()));
    std::vector<size_t> order(bands.size());
    std::iota(order.begin(), order.end(), size_t{0});
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
        return bands[a].stream.size() > bands[b].stream.size();
    });
    std::vector<std::vector<size_t>> share(shares);
    std::vector<size_t> load(shares, 0);
    for (size_t t : order) {
        const size_t k =
            static_cast<size_t>(std::min_element(load.begin(), load.end()) - load.begin());
        share[k].push_back(t);
        load[k] += bands[t].stream.size() + 1;
    }
    parallel_for(static_cast<int64_t>(shares), [&](int64_t begin, int64_t end) {
        for (auto k = static_cast<size_t>(begin); k < static_cast<size_t>(end); ++k) {
            for (size_t t : share[k]) add_decoded_residual(domain, bands[t], x[t], version);
        }
    });
    temporal_inverse(x, temporal_levels(frames, tree), tree);
    return x;
}

void synthesize_frames(const CodingDomain& domain, std::span<Planes> coefficients,
                       std::span<const std::vector<Vec2>> vertices, std::span<Image> images,
                       std::span<const std::optional<RenderPlan>> plans) {
    if (coefficients.size() < images.size() || vertices.size() < images.size() ||
        (!plans.empty() && plans.size() < images.size())) {
        throw Error("lifted group: fewer frames than images");
    }
    parallel_for(static_cast<int64_t>(images.size()), [&](int64_t begin, int64_t end) {
        for (auto k = static_cast<size_t>(begin); k < static_cast<size_t>(end); ++k) {
            const RenderPlan* plan = !plans.empty() && plans[k] ? &*plans[k] : nullptr;
            domain.synthesize(std::move(coefficients[k]), vertices[k], images[k], plan);
        }
    });
}

}  // namespace tesswave::video
