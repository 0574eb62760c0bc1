// The coding domain of a .twv group, shared by the encoder and the decoder: the group's topology
// (hierarchy and coding layout of the grid mesh T0, or the fixed grid on the pixel lattice),
// built once, and per frame the transform of an image sampled on that frame's vertex positions
// (analysis) or its inverse rendered to pixels (synthesis). One topology, many position sets.
#pragma once

#include <optional>
#include <span>
#include <vector>

#include "core/coding_layout.h"
#include "core/geometry.h"
#include "core/hierarchy.h"
#include "core/image.h"
#include "core/mesh.h"
#include "twv_format.h"

namespace tesswave::video {

using Planes = std::vector<std::vector<float>>;

class TwvDomain {
  public:
    // Norms are measured (encoder) when `measure_norms`, else taken from the group (decoder).
    TwvDomain(const TwvHeader& header, const TwvGroup& group, bool measure_norms);

    const CodingLayout& layout() const { return layout_; }
    bool is_mesh() const { return hierarchy_.has_value(); }
    // The T0 grid mesh (mesh path) at its rest positions: grid_mesh(W, H, cols, rows) rounded to
    // the motion grid (mesh_motion.h).
    const Mesh& mesh() const { return mesh_; }
    int32_t size() const { return layout_.size; }
    // Quantizer step of a band in a channel for a frame's base step.
    float step(int channel, int band, float base_step) const;
    // The steps of every band in a channel.
    std::vector<float> band_steps(int channel, float base_step) const;
    // Planes of the group's shape, all zero.
    Planes zeros() const;

    // Coefficients of `image` sampled on the mesh with T0 vertex positions `vertices` (mesh
    // path; ignored on the fixed grid). `out` is resized as needed.
    void analyze(const Image& image, std::span<const Vec2> vertices, Planes& out) const;
    // The image of `coefficients` (consumed) on those vertex positions.
    void synthesize(Planes coefficients, std::span<const Vec2> vertices, Image& out) const;

  private:
    TwvHeader header_;
    TwvGroup group_;
    Mesh mesh_;
    std::optional<Hierarchy> hierarchy_;
    CodingLayout layout_;
};

// Decodes a frame's bit-planes and adds the dequantized residual to `coefficients` (the previous
// frame's decoded coefficients, or zeros for an intra frame): the one step the encoder and the
// decoder share, so that both hold the same coefficients to the bit.
void add_decoded_residual(const TwvDomain& domain, const TwvFrame& frame, Planes& coefficients);

}  // namespace tesswave::video
