// Projection of an image onto a mesh: the level-J samples that the renderer turns into the image
// most closely, where point sampling (sampling.h) only reads the image at the sample positions.
//
// Rendering is linear in the samples, render(s) = R s, with four bilinear weights a pixel
// (render.h). project_image returns, for each channel, the s that minimises
//
//     E(s) = sum_p m_p ((R s)_p - I_p)^2  +  alpha u sum_k (s_k - a_k)^2
//                                         +  beta u sum_(k,l) (s_k - s_l)^2
//
// where p runs over the pixels, m_p is 0 for a pixel with a non-finite value in any channel and 1
// otherwise, a is the anchor (the prefiltered point samples unless the caller gives one), (k, l)
// runs over the edges of every quad's level-J sample grid, and u = pixels / samples scales both
// weights to the data term. alpha keeps the problem well posed where faces are smaller than
// pixels (samples no pixel reads stay at the anchor); beta damps the finest bands, where an
// unregularized fit sharpens (it undoes the renderer's bilinear blur) and puts energy a coder has
// to pay for. The normal equations (R^T M R + alpha u I + beta u L) s = R^T M I + alpha u a are
// solved by conjugate gradients with a Jacobi preconditioner, warm-started from the anchor; R^T R
// is assembled once per call as a 3x3 stencil per node of each quad's grid, and the iterations run
// on those grids (a sample on a quad border has a copy in each quad). Memory: about 130 bytes a
// sample at 32 cells a quad side (stencils; five vectors of three channels and two of one on the
// grids; the anchor and the result; the grids' part grows as (m + 1)^2 / m^2 at m cells a side:
// 2.25 times at 2, 4 times at 1) plus the render plan's 9 bytes a pixel, on top of the hierarchy;
// its 50-million-sample limit bounds both.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string_view>
#include <vector>

#include "core/math/geometry.h"
#include "core/math/hierarchy.h"
#include "core/math/image.h"
#include "core/math/render.h"

namespace tesswave {

// The conjugate gradients' preconditioner. `lines` approximates each quad's block of the normal
// matrix by a product of two tridiagonal matrices, one along its grid's rows and one along its
// columns (project_grids.h), and inverts that: at about a sample a pixel, where rendering blurs
// like [1 2 1] / 4 along each axis, it reaches in 4 iterations what `jacobi` (the diagonal) reaches
// in 20. Quads of more than 1.4 cells a pixel keep Jacobi, which converges there in a few
// iterations.
enum class Preconditioner : uint8_t { jacobi, lines };

struct ProjectOptions {
    int level = -1;               // -1: the finest level
    double anchor_weight = 1e-3;  // alpha, > 0
    double smoothness = 0.0;      // beta, >= 0
    int max_iterations = 30;      // conjugate-gradient iterations, 0 .. 1000
    double tolerance = 1e-4;      // stop when each channel's residual is this part of its b
    Preconditioner preconditioner = Preconditioner::lines;
    // One plane per channel (the level's sample count each); empty: the prefiltered point samples.
    std::span<const std::span<const float>> anchor = {};
    // The render plan of these vertex positions at the image's size and this level, when the
    // caller keeps one (a coding domain at rest); null: made here. It must outlive the call.
    const RenderPlan* plan = nullptr;
};

struct Projection {
    std::vector<std::vector<float>> planes;  // one per channel, the level's samples
    int iterations = 0;                      // conjugate-gradient iterations run
    double residual = 0;                     // largest relative residual of the normal equations
};

// The mesh domain is taken to be the image's pixel rectangle, as in sample_image. Throws Error
// for a level out of range, bad options or an anchor of the wrong size.
Projection project_image(const Image& image, const Hierarchy& hierarchy,
                         std::span<const Vec2> mesh_vertices, const ProjectOptions& options = {});

// The projections for several smoothness values (options.smoothness is not used), handed to
// `take` in order as each is solved. The plan and the data term are assembled once for all, and
// each solve starts from the one before it (the solutions for neighbouring values are close), so
// that n values cost far less than n calls. The first equals project_image's; a later one may
// differ from project_image's within the tolerance, as another starting point gives.
void project_image_each(const Image& image, const Hierarchy& hierarchy,
                        std::span<const Vec2> mesh_vertices, std::span<const double> smoothness,
                        const ProjectOptions& options,
                        const std::function<void(size_t, const Projection&)>& take);

// How an image is put on a mesh: point sampling (sample_image) or the projection above.
enum class Sampling : uint8_t { point, fit };

// "point" or "fit"; Error for anything else.
Sampling sampling_from_name(std::string_view name);
const char* sampling_name(Sampling sampling);

// The image's samples at level `level` (-1: the finest) by either method.
std::vector<std::vector<float>> place_image(const Image& image, const Hierarchy& hierarchy,
                                            std::span<const Vec2> mesh_vertices, Sampling sampling,
                                            int level = -1, const ProjectOptions& options = {});

}  // namespace tesswave
