#include "twv_domain.h"

#include "core/bitplane.h"
#include "core/colour.h"
#include "core/error.h"
#include "core/fixed_grid.h"
#include "core/grid_mesh.h"
#include "core/lifting.h"
#include "core/render.h"
#include "core/sampling.h"
#include "core/strings.h"
#include "mesh_motion.h"

namespace tesswave::video {
namespace {

std::vector<std::span<float>> spans(Planes& planes) { return {planes.begin(), planes.end()}; }

GridTransformOptions grid_options(const TwvGroup& g) {
    return {
        .wavelet = g.transform == TwiTransform::grid97 ? GridWavelet::cdf97 : GridWavelet::cdf53,
        .levels = g.levels};
}

}  // namespace

TwvDomain::TwvDomain(const TwvHeader& header, const TwvGroup& group, bool measure_norms)
    : header_(header), group_(group) {
    const int W = header.width, H = header.height;
    if (group.transform == TwiTransform::mesh) {
        // Rest positions on the motion grid, so that a mesh that does not move codes no motion.
        mesh_ = grid_mesh(W, H, group.grid_cols, group.grid_rows);
        mesh_.vertices = round_to_motion_unit(mesh_.vertices);
        hierarchy_ = build_hierarchy(mesh_, {.levels = group.levels});
        layout_ = mesh_layout(*hierarchy_, double{1} * W * H, measure_norms ? 1 : 0);
    } else {
        const GridTransformOptions o = grid_options(group);
        layout_ = grid_layout(W, H, group.levels, o.wavelet, measure_norms);
    }
    if (!measure_norms) {
        if (group.band_norms.size() != layout_.bands.size()) {
            throw Error("group band count does not match its coding layout");
        }
        for (size_t b = 0; b < layout_.bands.size(); ++b)
            layout_.bands[b].norm = group.band_norms[b];
    }
}

float TwvDomain::step(int channel, int band, float base_step) const {
    return base_step * group_.channel_factors[channel] /
           static_cast<float>(layout_.bands[band].norm);
}

std::vector<float> TwvDomain::band_steps(int channel, float base_step) const {
    std::vector<float> steps(layout_.bands.size());
    for (size_t b = 0; b < steps.size(); ++b) {
        steps[b] = step(channel, static_cast<int>(b), base_step);
    }
    return steps;
}

Planes TwvDomain::zeros() const {
    return Planes(header_.channels, std::vector<float>(size(), 0.0f));
}

void TwvDomain::analyze(const Image& image, std::span<const Vec2> vertices, Planes& out) const {
    if (image.width != header_.width || image.height != header_.height ||
        image.channels() != header_.channels) {
        throw Error(str("frame is ", image.width, "x", image.height, " with ", image.channels(),
                        " channels; the clip is ", header_.width, "x", header_.height, " with ",
                        header_.channels));
    }
    out.resize(header_.channels);
    for (auto& plane : out) plane.resize(size());
    if (hierarchy_) {
        sample_image_into(image, *hierarchy_, vertices, spans(out));
    } else {
        for (int c = 0; c < header_.channels; ++c) out[c] = image.planes[c];
    }
    if (header_.channels == 3) ycbcr_forward(out[0], out[1], out[2]);
    if (hierarchy_) {
        forward_transform(*hierarchy_, spans(out));
    } else {
        for (auto& plane : out)
            grid_forward(plane, header_.width, header_.height, grid_options(group_));
    }
}

void TwvDomain::synthesize(Planes x, std::span<const Vec2> vertices, Image& out) const {
    if (hierarchy_) {
        inverse_transform(*hierarchy_, spans(x));
    } else {
        for (auto& plane : x)
            grid_inverse(plane, header_.width, header_.height, grid_options(group_));
    }
    if (header_.channels == 3) ycbcr_inverse(x[0], x[1], x[2]);
    if (hierarchy_) {
        const RenderPlan plan = plan_render(*hierarchy_, vertices, header_.width, header_.height,
                                            header_.width, header_.height);
        out = make_image(header_.width, header_.height, header_.channels);
        std::vector<std::span<const float>> in(x.begin(), x.end());
        render_into(plan, in, out);
    } else {
        out = make_image(header_.width, header_.height, header_.channels);
        out.planes = std::move(x);
    }
}

void add_decoded_residual(const TwvDomain& domain, const TwvFrame& frame, Planes& x) {
    const CodingLayout& layout = domain.layout();
    const BitplaneOptions options{.shifts = std::vector<int>(layout.bands.size(), 0)};
    const DecodedPlanes d = decode_bitplanes(layout, frame.planes, frame.stream, options);
    std::vector<float> r(layout.size);
    for (size_t c = 0; c < x.size(); ++c) {
        const int channel = static_cast<int>(c);
        dequantize(layout, d, channel, domain.band_steps(channel, frame.base_step), false, r);
        for (int32_t i = 0; i < layout.size; ++i) x[c][i] += r[i];
    }
}

}  // namespace tesswave::video
