// Rendering a function on T_j to pixels (DESIGN.md 2.5). Each T1 quad is rasterized (pixel
// centres, half-open top-left rule, so every pixel belongs to exactly one quad), the pixel's (u,v)
// comes from the inverse bilinear map, and the value is the bilinear interpolation of the four
// level-j grid samples around (u m, v m). The result is C0 across quads: on a shared edge both
// sides interpolate the same edge samples.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <type_traits>
#include <vector>

#include "core/math/hierarchy.h"
#include "core/math/image.h"
#include "core/math/parallel.h"
#include "core/math/raw_vector.h"

#if defined(__SSE2__)
#include <immintrin.h>
#endif

namespace tesswave {

// Where each pixel reads from: a plan for one geometry, level and output size, applied to any
// number of planes (like the maps of cv::remap). Pixels are grouped by T1 quad, so rendering
// stages one quad's grid of values at a time and interpolates its pixels from that small buffer.
struct RenderPlan {
    int width = 0, height = 0, level = 0;
    int32_t samples = 0;      // of the level: every plane needs at least this many values
    int32_t cells = 0;        // m, cells a quad side
    RawVector<int32_t> grid;  // the level's patch grids, (m+1)^2 sample ids a quad
    // Pixels of a quad as row runs: run k covers pixels [run_start[k], run_start[k] +
    // run_length[k]) of the output, in order; quad q owns runs [quad_runs[q], quad_runs[q+1]).
    std::vector<int32_t> quad_runs;
    std::vector<int32_t> run_start, run_length;
    // Per pixel, in run order: the grid cell r (m+1) + c it lies in, and its fractions along c
    // and r in 16-bit fixed point (units of 2^-16; error below 2^-17 of a cell).
    RawVector<int32_t> cell;
    RawVector<std::array<uint16_t, 2>> st;
};

struct RenderOptions {
    int level = -1;  // -1: the finest level of the hierarchy
};

// Output pixel (i, k) has its centre at ((i + 1/2) W / width, (k + 1/2) H / height) of the
// domain [0,W]x[0,H]. Throws Error for sizes out of range.
RenderPlan plan_render(const Hierarchy& hierarchy, std::span<const Vec2> mesh_vertices,
                       double domain_width, double domain_height, int width, int height,
                       const RenderOptions& options = {});

// One output plane per input plane; each input plane holds at least the level's samples.
Image render(const RenderPlan& plan, std::span<const std::span<const float>> planes,
             SampleFormat format = SampleFormat::u8);

// The same into an image of the plan's size with one plane per input plane (reused buffers).
void render_into(const RenderPlan& plan, std::span<const std::span<const float>> planes,
                 Image& out);

// Where each quad's entries start in the plan: quad q's pixel runs read st and cell entries
// [starts[q], starts[q + 1]).
std::vector<size_t> plan_entry_starts(const RenderPlan& plan);

// Throws Error unless every plane holds the plan level's samples, and there are `count` planes
// (0: any number).
void check_render_planes(const RenderPlan& plan, std::span<const std::span<const float>> planes,
                         int count = 0);

// Where a pixel lies: its T1 quad (in t1_quads' order) and its (u, v) in that quad's bilinear
// map, from the plan's cell and fractions (float precision).
struct PlanPlace {
    int32_t quad = 0;
    float u = 0, v = 0;
};

// render_runs hands a row of a quad's pixels over in pieces of at most kRunPixels.
inline constexpr int32_t kRunPixels = 256;

namespace detail {

// Planes staged side by side in groups of four, one SSE register a grid sample and group, for 2 to
// 8 planes: a pixel then loads 4 registers a group where it loaded 4 floats a plane. 0: one plane
// after the other (one plane, a count only known at run time, or more than 8).
template <int C>
constexpr int kStagedGroups =
#if defined(__SSE2__)
    C >= 2 && C <= 8 ? (C + 3) / 4 : 0;
#else
    0;
#endif

// values[0, 4 G) = the bilinear interpolation at fractions (s, r) of the staged cell v (its four
// corners at v, v + L, v + side L, v + (side + 1) L with L = 4 G): the same operations, in the same
// order, as the one-plane path.
template <int G>
inline void interpolate_groups(const float* v, int32_t side, float s, float r, float* values) {
#if defined(__SSE2__)
    constexpr int32_t L = 4 * G;
    const __m128 s4 = _mm_set1_ps(s), r4 = _mm_set1_ps(r);
    for (int g = 0; g < G; ++g) {
        const float* p = v + 4 * g;
        const __m128 a = _mm_loadu_ps(p), b = _mm_loadu_ps(p + L);
        const __m128 c = _mm_loadu_ps(p + side * L), d = _mm_loadu_ps(p + (side + 1) * L);
        const __m128 top = _mm_add_ps(a, _mm_mul_ps(_mm_sub_ps(b, a), s4));
        const __m128 bottom = _mm_add_ps(c, _mm_mul_ps(_mm_sub_ps(d, c), s4));
        _mm_store_ps(values + 4 * g, _mm_add_ps(top, _mm_mul_ps(_mm_sub_ps(bottom, top), r4)));
    }
#else
    (void)v, (void)side, (void)s, (void)r, (void)values;
#endif
}

}  // namespace detail

// A piece of a row of output pixels in one quad: pixels [start, start + length); pixel n's
// rendered value of plane c at values[n * stride + c] (with 2 to 8 planes, the stride is a
// multiple of 4 and each pixel's values are 16-byte aligned); when render_runs is asked for
// places, each pixel's (u, v) in the quad's bilinear map (as PlanPlace has them).
struct RenderRun {
    int32_t quad = 0, start = 0, length = 0, stride = 0;
    const float* values = nullptr;
    const float* u = nullptr;
    const float* v = nullptr;
};

// Calls f(run) for every piece of every row run of the plan, the values of each plane being what
// render() gives, to the bit: render_into itself, and callers that use the rendered values at once
// (a warp through the mesh map) instead of keeping images of them. C is the plane count (0:
// planes.size(), any; a fixed count unrolls the channel loop). One quad at a time: its grid values
// of every plane staged side by side (the next quad's asked for meanwhile), then its pixel runs
// read their plan entries once. The quads are shared among the cores, so f runs concurrently, on
// disjoint pixels.
template <int C, bool Places, class F>
void render_runs(const RenderPlan& plan, std::span<const std::span<const float>> planes, F&& f) {
    check_render_planes(plan, planes, C);
    const std::vector<size_t> starts = plan_entry_starts(plan);
    const int32_t side = plan.cells + 1, grid_size = side * side;
    const float inverse_m = 1.0f / static_cast<float>(plan.cells);
    const size_t channels = C > 0 ? static_cast<size_t>(C) : planes.size();
    parallel_for(
        static_cast<int64_t>(plan.quad_runs.size()) - 1,
        [&](int64_t begin, int64_t end) {
            constexpr float kUnit = 1.0f / 65536.0f;
            constexpr int G = detail::kStagedGroups<C>;
            constexpr size_t L = 4 * G;  // a staged grid sample's floats, when grouped
            std::vector<float> local(static_cast<size_t>(grid_size) * (G > 0 ? L : channels));
            // Pixel n's values at n * stride: groups of 4, 16-byte aligned as operator new aligns.
            const size_t stride = G > 0 ? L : channels;
            std::vector<float> values(kRunPixels * stride);
            std::vector<float> us(Places ? kRunPixels : 0), vs(us.size());
            for (int64_t q = begin; q < end; ++q) {
                const int32_t* ids = plan.grid.data() + q * grid_size;
                if constexpr (G > 0) {
                    // A node's values of every plane at once: one pass over the ids, and each
                    // node's group written whole.
                    const float* x[C > 0 ? C : 1];
                    for (size_t c = 0; c < channels; ++c) x[c] = planes[c].data();
                    float* __restrict g = local.data();
                    for (int32_t k = 0; k < grid_size; ++k) {
                        const int32_t id = ids[k];
                        for (size_t c = 0; c < channels; ++c) g[k * L + c] = x[c][id];
                    }
                } else {
                    for (size_t c = 0; c < channels; ++c) {
                        const float* __restrict x = planes[c].data();
                        float* __restrict g = local.data() + c * grid_size;
                        for (int32_t k = 0; k < grid_size; ++k) g[k] = x[ids[k]];
                    }
                }
                // The next quad's grid values are fetched into the cache while this quad's pixels
                // are interpolated: the staging gather above is otherwise most of the time.
                if (q + 1 < end) {
                    const int32_t* next = ids + grid_size;
                    for (int32_t k = 0; k < grid_size; ++k) {
                        for (size_t c = 0; c < channels; ++c)
                            __builtin_prefetch(planes[c].data() + next[k]);
                    }
                }
                size_t i = starts[static_cast<size_t>(q)];
                for (int32_t run = plan.quad_runs[q]; run < plan.quad_runs[q + 1]; ++run) {
                    const int32_t start = plan.run_start[run], length = plan.run_length[run];
                    for (int32_t from = 0; from < length; from += kRunPixels) {
                        const int32_t count = std::min(kRunPixels, length - from);
                        float* __restrict to = values.data();
                        for (int32_t n = 0; n < count; ++n, ++i) {
                            const float s = plan.st[i][0] * kUnit, r = plan.st[i][1] * kUnit;
                            if constexpr (G > 0) {
                                detail::interpolate_groups<G>(local.data() + plan.cell[i] * L, side,
                                                              s, r, to + n * stride);
                            } else {
                                for (size_t c = 0; c < channels; ++c) {
                                    const float* v = local.data() + c * grid_size + plan.cell[i];
                                    const float top = v[0] + (v[1] - v[0]) * s;
                                    const float bottom = v[side] + (v[side + 1] - v[side]) * s;
                                    to[n * stride + c] = top + (bottom - top) * r;
                                }
                            }
                            if constexpr (Places) {
                                const int32_t cell = plan.cell[i], row = cell / side;
                                us[n] = (static_cast<float>(cell - row * side) + s) * inverse_m;
                                vs[n] = (static_cast<float>(row) + r) * inverse_m;
                            }
                        }
                        f(RenderRun{static_cast<int32_t>(q), start + from, count,
                                    static_cast<int32_t>(stride), values.data(), us.data(),
                                    vs.data()});
                    }
                }
            }
        },
        16);
}

// Calls f(pixel, values) for every pixel the plan renders, values[c] being what render() gives
// planes[c] there, to the bit (render_runs, a pixel at a time). An f that takes a third argument
// gets the pixel's PlanPlace too.
template <int C, class F>
void render_each(const RenderPlan& plan, std::span<const std::span<const float>> planes, F&& f) {
    constexpr bool places = std::is_invocable_v<F, int32_t, const float*, PlanPlace>;
    render_runs<C, places>(plan, planes, [&](const RenderRun& run) {
        for (int32_t n = 0; n < run.length; ++n) {
            const float* values = run.values + static_cast<size_t>(n) * run.stride;
            if constexpr (places) {
                f(run.start + n, values, PlanPlace{run.quad, run.u[n], run.v[n]});
            } else {
                f(run.start + n, values);
            }
        }
    });
}

}  // namespace tesswave
