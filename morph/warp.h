// The mesh map between a morph's images at the level of pixels: each T1 quad's bilinear map in
// floats, an image warped through a render plan, and the measures the aware schedule takes in
// A's pixels (the local agreement of A's and B's detail, the residuals' local energies).
#pragma once

#include <span>
#include <vector>

#include "core/math/geometry.h"
#include "core/math/image.h"
#include "core/math/parametrization.h"
#include "core/math/render.h"

namespace tesswave::morph {

// A T1 quad's bilinear map in floats, p(u, v) = (x, y) + u a + v b + u v c: where a frame's pixel
// lies in A and in B (the mesh map, from the pixel's place in its quad, render.h's PlanPlace).
struct QuadMap {
    float x, y, ax, ay, bx, by, cx, cy;
    Vec2 at(float u, float v) const {
        return {x + u * ax + v * bx + u * v * cx, y + u * ay + v * by + u * v * cy};
    }
};

// The maps of t1_quads' quads (corners p00, p10, p11, p01).
std::vector<QuadMap> quad_maps(const std::vector<Quad>& quads);

// Image b fetched bilinearly where the plan's pixels lie in b (quads: the T1 quads' maps into b's
// pixels): b warped onto the plan's mesh, an image of the plan's size.
Image warped_through(const RenderPlan& plan, std::span<const QuadMap> quads, const Image& b);

// The residual band warped into a frame: ra read where each pixel lies in A (maps_a) and, when
// both, rb where it lies in B (maps_b), weighted by ka and kb, or, with per_sample_weights, by the
// two planes rendered after the colour. The images are at least 2x2 pixels.
struct ResidualWarp {
    std::span<const QuadMap> maps_a, maps_b;
    const Image& ra;
    const Image& rb;
    float ka = 1, kb = 0;
    bool both = false, per_sample_weights = false;
};

// out = the colour planes (the first out.channels(), 3 or 4, of `planes`) rendered, plus the
// residual warp: the frame and its residual band in one pass over the plan. Four pixels at a time
// where the CPU has AVX2, the same bits as a pixel at a time.
void compose(const RenderPlan& plan, std::span<const std::span<const float>> planes,
             const ResidualWarp& warp, Image& out);

// Per pixel, how far the detail of a and b (the same size) agrees: detail is each image minus its
// 5x5 box mean, and c = max(0, <Da, Db> / (|Da| |Db|)) over the colour channels and a 9x9 window
// (the definition compare-morph measures a middle frame with, core/eval/peer_morph.h). One plane.
// Throws Error when the images differ in size or channels (as residual_energies does).
Image detail_agreement(const Image& a, const Image& b);

// Three planes per pixel: the local energies of the residuals ra and rb (the same size) and their
// inner product, summed over channels and a 7x7 window.
std::vector<std::vector<float>> residual_energies(const Image& ra, const Image& rb);

}  // namespace tesswave::morph
