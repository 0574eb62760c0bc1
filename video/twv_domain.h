// The coding domain of a .twv group, shared by the encoder and the decoder: the core codec's
// CodingDomain built from the group's topology (the grid mesh T0 at rest, rounded to the motion
// grid, or the fixed grid on the pixel lattice); per frame it is used with that frame's vertex
// positions. One topology, many position sets. A group with a canvas (TwvGroup::extend_x/y) has
// T0 on the canvas, and each frame's positions in that frame's pixels: on the canvas less the
// frame's window (window_vertices).

#pragma once

#include <memory>
#include <span>
#include <vector>

#include "core/codec/coding_domain.h"
#include "temporal.h"
#include "twv_format.h"

namespace tesswave::video {

using tesswave::Planes;

// Norms are measured (encoder) when `measure_norms`, else taken from the group (decoder). From
// the domain cache (shared_domain): an encoder and decoder in one process share the hierarchy;
// a canvas is built for its group alone.
std::shared_ptr<const CodingDomain> group_domain(const TwvHeader& header, const TwvGroup& group,
                                                 bool measure_norms);

// How the bit-plane streams of a file of this version are coded: models that learn fast while
// fresh from version 2 (range_coder.h), zero blocks from version 6 (bitplane.h).
BitplaneOptions twv_stream_options(const CodingLayout& layout, int version);

// Decodes a frame's bit-planes and adds the dequantized residual to `coefficients` (the previous
// frame's decoded coefficients, or zeros for an intra frame): the one step the encoder and the
// decoder share, so that both hold the same coefficients to the bit. `version`: the file's
// (twv_stream_options).
void add_decoded_residual(const CodingDomain& domain, const TwvFrame& frame, Planes& coefficients,
                          int version);

// A lifted group's frame coefficients from its temporal bands: bands[t] is slot t, slots from
// bands.size() up to `frames` (a group cut short) are zero; then the temporal inverse. The one
// path of the encoder's reconstruction and the decoder.
// A window's place on its canvas in pixels, from its left and top in 1/4 pixels; and canvas
// positions in the frame's pixels (less the frame's window): the encoder's and decoder's one way.
Vec2 window_offset(int32_t left, int32_t top);
std::vector<Vec2> window_vertices(std::span<const Vec2> canvas, const TwvFrame& frame);

std::vector<Planes> decode_lifted_group(const CodingDomain& domain, std::span<const TwvFrame> bands,
                                        int frames, TemporalTree tree, int version);

// The temporal tree of a file's lifted groups: dyadic before version 4, bisection from it.
TemporalTree temporal_tree(const TwvHeader& header);

// Renders images.size() frames of a lifted group, the coefficients (moved from, as synthesize
// takes them) and vertices of frame k at coefficients[k] and vertices[k] into images[k]: a frame
// per core at a time, each frame's own kernels on its core (small frames split badly). `plans`,
// when not empty, holds domain.plan_for(vertices[k]) at k (kept by an encoder's step search).
void synthesize_frames(const CodingDomain& domain, std::span<Planes> coefficients,
                       std::span<const std::vector<Vec2>> vertices, std::span<Image> images,
                       std::span<const std::optional<RenderPlan>> plans = {});

}  // namespace tesswave::video
