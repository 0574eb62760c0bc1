// Sampling an image at the vertex positions of T_j (DESIGN.md 2.5): bilinear in the pixel grid,
// with pixel (i,k)'s value at its centre (i+1/2, k+1/2) and edges clamped. Where the mesh is
// coarser than the pixels (a T_j cell spans more than one pixel) the image is prefiltered: it is
// read from a mip pyramid of 2x2 box averages at the level matching the cell's size, blending the
// two nearest pyramid levels (trilinear), so coarse meshes average instead of aliasing. Cells whose
// area is at most that of a square 1.07 pixels a side read the image alone. Quads are sampled in
// parallel; a sample on the border of several quads is written by the last of them, whatever the
// thread count.
#pragma once

#include <algorithm>
#include <cstddef>
#include <span>
#include <vector>

#include "core/math/geometry.h"
#include "core/math/hierarchy.h"
#include "core/math/image.h"

namespace tesswave {

// Bilinear weights of one position on an image (or a pyramid level of it, inv_size = 2^-level),
// shared by all channels: the four pixels around it, clamped to the image, and the fractions.
struct Tap {
    size_t i00, i01, i10, i11;
    float tx, ty;
};

inline Tap bilinear_tap(int w, int h, double inv_size, Vec2 p) {
    const double fx = std::clamp(p.x * inv_size - 0.5, 0.0, w - 1.0);
    const double fy = std::clamp(p.y * inv_size - 0.5, 0.0, h - 1.0);
    const int x0 = std::min(static_cast<int>(fx), std::max(w - 2, 0));
    const int y0 = std::min(static_cast<int>(fy), std::max(h - 2, 0));
    const int x1 = std::min(x0 + 1, w - 1), y1 = std::min(y0 + 1, h - 1);
    return {static_cast<size_t>(y0) * w + x0, static_cast<size_t>(y0) * w + x1,
            static_cast<size_t>(y1) * w + x0, static_cast<size_t>(y1) * w + x1,
            static_cast<float>(fx - x0),      static_cast<float>(fy - y0)};
}

// The value of `plane` at the tap, as sample_bilinear gives it.
inline float bilinear_at(const Tap& t, const float* plane) {
    const float top = plane[t.i00] + (plane[t.i01] - plane[t.i00]) * t.tx;
    const float bottom = plane[t.i10] + (plane[t.i11] - plane[t.i10]) * t.tx;
    return top + (bottom - top) * t.ty;
}

// Plain bilinear lookups, one plane per image channel, one value per position.
std::vector<std::vector<float>> sample_bilinear(const Image& image,
                                                std::span<const Vec2> positions);

struct SampleOptions {
    int level = -1;         // -1: the finest level
    bool prefilter = true;  // mip-mapped where cells are larger than a pixel (1.07 a side)
    // Four nodes at a time with AVX2 where the CPU has it; false: one node at a time. Both
    // evaluate the same expressions in the same order, so the samples are identical to the bit
    // (a test pins this).
    bool vector = true;
};

// The image at every sample of the level; the mesh domain is taken to be the image's pixel
// rectangle (callers check or scale it). Returns one plane per channel.
std::vector<std::vector<float>> sample_image(const Image& image, const Hierarchy& hierarchy,
                                             std::span<const Vec2> mesh_vertices,
                                             const SampleOptions& options = {});

// The same into caller-owned planes (one per channel, each the level's sample count), so that
// repeated sampling (video frames) reuses its buffers.
void sample_image_into(const Image& image, const Hierarchy& hierarchy,
                       std::span<const Vec2> mesh_vertices, std::span<const std::span<float>> out,
                       const SampleOptions& options = {});

// Which border nodes of its grid each T1 quad writes when sampling: a node that several quads
// hold (on a T1 edge or at a T1 vertex) belongs to the last of them in order. Bit s (0..3): the
// inner nodes of side s, which runs from corner s to corner s + 1 (grid row 0, column m, row m,
// column 0); bit 4 + s: corner s (grid node (0, 0), (0, m), (m, m), (m, 0)). From T1's topology,
// without a pass over the nodes.
std::vector<uint8_t> quad_border_ownership(const Hierarchy& hierarchy);

// The bit of quad_border_ownership for border node (r, c) of a grid of m cells a side.
inline uint8_t border_bit(int32_t r, int32_t c, int32_t m) {
    if (r == 0) return c == 0 ? 16 : c == m ? 32 : 1;
    if (r == m) return c == m ? 64 : c == 0 ? 128 : 4;
    return c == m ? 2 : 8;
}

// The level whose sample count is closest (in ratio) to `density` samples per pixel: J of a mesh
// the caller gives (morph, analyze, the still codec's --mesh).
int level_for_density(const Mesh& mesh, int pixels, double density, int max_level = 12);

// The grid the codecs build when no mesh is given: J from 1 to 7 so that the image's shorter side
// gets 8 to 16 T0 cells, then as many cells as make `density` samples a pixel at level J. The one
// rule for J: level_for_density of this grid gives back `levels` (a test checks it). A positive
// `levels` fixes J and only sizes the cells.
struct DefaultGrid {
    int levels = 1;
    int cols = 1;
    int rows = 1;
};
DefaultGrid default_grid(int width, int height, double density, int levels = 0);

}  // namespace tesswave
