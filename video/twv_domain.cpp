#include "twv_domain.h"

#include "core/codec/bitplane.h"
#include "core/math/error.h"
#include "core/math/grid_mesh.h"
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
        rest = grid_mesh(header.width, header.height, group.grid_cols, group.grid_rows);
        rest.vertices = round_to_motion_unit(rest.vertices);
    }
    DomainShape shape{.transform = group.transform,
                      .width = header.width,
                      .height = header.height,
                      .channels = header.channels,
                      .colour = header.channels == 3 ? TwiColour::ycbcr : TwiColour::none,
                      .levels = group.levels,
                      .mesh = std::move(rest),
                      .channel_factors = group.channel_factors};
    return shared_domain(shape, measure_norms ? 1 : 0,
                         measure_norms ? std::span<const float>() : group.band_norms);
}

void add_decoded_residual(const CodingDomain& domain, const TwvFrame& frame, Planes& x,
                          bool fast_start) {
    const CodingLayout& layout = domain.layout();
    const BitplaneOptions options{.shifts = std::vector<int>(layout.bands.size(), 0),
                                  .fast_start = fast_start};
    const DecodedPlanes d = decode_bitplanes(layout, frame.planes, frame.stream, options);
    std::vector<float> r(layout.size);
    for (size_t c = 0; c < x.size(); ++c) {
        const int channel = static_cast<int>(c);
        dequantize(layout, d, channel, domain.band_steps(channel, frame.base_step), false, r);
        for (int32_t i = 0; i < layout.size; ++i) x[c][i] += r[i];
    }
}

std::vector<Planes> decode_lifted_group(const CodingDomain& domain, std::span<const TwvFrame> bands,
                                        int frames) {
    if (frames < 1 || bands.size() > static_cast<size_t>(frames)) {
        throw Error("lifted group: more bands than frames");
    }
    std::vector<Planes> x(static_cast<size_t>(frames), domain.zeros());
    for (size_t t = 0; t < bands.size(); ++t) add_decoded_residual(domain, bands[t], x[t]);
    temporal_inverse(x, temporal_levels(frames));
    return x;
}

}  // namespace tesswave::video
