#include "core/math/render.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "core/math/error.h"
#include "core/math/parallel.h"
#include "core/math/parametrization.h"
#include "core/math/strings.h"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace tesswave {
namespace {

// x where the line y = yc crosses edge (a, b), the endpoints ordered so that both faces sharing
// the edge compute the very same number.
double crossing(Vec2 a, Vec2 b, double yc) {
    if (a.y > b.y || (a.y == b.y && a.x > b.x)) std::swap(a, b);
    return a.x + (b.x - a.x) * ((yc - a.y) / (b.y - a.y));
}

// The pixel columns [first, last) of row k whose centres lie in the convex quad q (pixel units).
// Edges are half-open in y ([ymin, ymax)), spans half-open in x: shared edges go to one side.
bool row_span(const Quad& q, double yc, int& first, int& last) {
    double xl = INFINITY, xr = -INFINITY;
    int hits = 0;
    for (int s = 0; s < 4; ++s) {
        const Vec2 a = q[s], b = q[(s + 1) % 4];
        const double y0 = std::min(a.y, b.y), y1 = std::max(a.y, b.y);
        if (!(yc >= y0 && yc < y1)) continue;
        const double x = crossing(a, b, yc);
        xl = std::min(xl, x);
        xr = std::max(xr, x);
        ++hits;
    }
    if (hits < 2) return false;
    first = static_cast<int>(std::ceil(xl - 0.5));
    last = static_cast<int>(std::ceil(xr - 0.5));
    return last > first;
}

// std::round(f * 65536) for f in [0, 1]: the integer part, plus one from a half up (the fraction
// x - whole is exact), without a call to libm.
inline uint16_t fixed16(double f) {
    const double x = f * 65536.0;
    const auto whole = static_cast<int32_t>(x);  // f is in [0, 1] (plan_run clamps u and v)
    const int32_t rounded = whole + (x - static_cast<double>(whole) >= 0.5);
    return static_cast<uint16_t>(std::min<int32_t>(65535, rounded));
}

// Plan entries [0, n) from the pixels' (u, v) (clamped to [0, 1]: a degenerate quad can leave
// u outside it, as QuadInverse keeps the raw root when no root scores, and the cell and the
// fractions must stay in range).
void plan_entries(const double* u, const double* v, int32_t n, int32_t m, int32_t* cell,
                  std::array<uint16_t, 2>* st) {
    for (int32_t j = 0; j < n; ++j) {
        const double s = std::clamp(u[j], 0.0, 1.0) * m, r = std::clamp(v[j], 0.0, 1.0) * m;
        const int32_t c0 = std::min(static_cast<int32_t>(s), m - 1);
        const int32_t r0 = std::min(static_cast<int32_t>(r), m - 1);
        cell[j] = r0 * (m + 1) + c0;
        st[j] = {fixed16(s - c0), fixed16(r - r0)};
    }
}

#if defined(__x86_64__)
#define TESSWAVE_AVX2 [[gnu::target("avx2"), gnu::always_inline]] inline

// For four values x = clamp(u, 0, 1) m: the cell index min(int(x), m - 1) and fixed16(x - cell),
// as plan_entries computes them (u is finite: QuadInverse's results are).
TESSWAVE_AVX2 void cell_fraction4(__m256d u, __m256d m, __m128i last, __m128i& index,
                                  __m128i& fraction) {
    const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0);
    // std::clamp(u, 0, 1): 0 if u < 0, else 1 if 1 < u, else u.
    const __m256d clamped =
        _mm256_blendv_pd(_mm256_blendv_pd(u, one, _mm256_cmp_pd(one, u, _CMP_LT_OQ)), zero,
                         _mm256_cmp_pd(u, zero, _CMP_LT_OQ));
    const __m256d x = _mm256_mul_pd(clamped, m);
    index = _mm_min_epi32(_mm256_cvttpd_epi32(x), last);
    const __m256d f =
        _mm256_mul_pd(_mm256_sub_pd(x, _mm256_cvtepi32_pd(index)), _mm256_set1_pd(65536.0));
    const __m128i whole = _mm256_cvttpd_epi32(f);
    const __m256d half_up =
        _mm256_cmp_pd(_mm256_sub_pd(f, _mm256_cvtepi32_pd(whole)), _mm256_set1_pd(0.5), _CMP_GE_OQ);
    // The comparison's all-ones lanes, narrowed to int32, are -1: subtracting adds one.
    const __m128i up = _mm256_cvtpd_epi32(_mm256_and_pd(half_up, _mm256_set1_pd(-1.0)));
    fraction = _mm_min_epi32(_mm_sub_epi32(whole, up), _mm_set1_epi32(65535));
}

#undef TESSWAVE_AVX2

// plan_entries four pixels at a time, the last four overlapping the four before; n >= 4.
[[gnu::target("avx2")]] void plan_entries_avx2(const double* u, const double* v, int32_t n,
                                               int32_t m, int32_t* cell,
                                               std::array<uint16_t, 2>* st) {
    const __m256d scale = _mm256_set1_pd(m);
    const __m128i last = _mm_set1_epi32(m - 1), side = _mm_set1_epi32(m + 1);
    for (int32_t next = 0; next < n; next += 4) {
        const int32_t j = std::min(next, n - 4);
        __m128i c0, fs, r0, fr;
        cell_fraction4(_mm256_loadu_pd(u + j), scale, last, c0, fs);
        cell_fraction4(_mm256_loadu_pd(v + j), scale, last, r0, fr);
        _mm_storeu_si128(reinterpret_cast<__m128i*>(cell + j),
                         _mm_add_epi32(_mm_mullo_epi32(r0, side), c0));
        // st[j] = {s, r}: s in the low half of each 32-bit pair.
        _mm_storeu_si128(reinterpret_cast<__m128i*>(st + j),
                         _mm_or_si128(fs, _mm_slli_epi32(fr, 16)));
    }
}
#endif

// The plan entries of one row run of a quad: each pixel's grid cell and fractions, from the
// quad's inverse bilinear map (QuadInverse::row, four pixels at a time) in chunks on the stack.
void plan_run(const QuadInverse& inverse, int32_t first, int32_t length, int32_t k, int32_t m,
              int32_t* cell, std::array<uint16_t, 2>* st) {
    constexpr int32_t kChunk = 64;
    double u[kChunk], v[kChunk];
#if defined(__x86_64__)
    static const bool avx2 = __builtin_cpu_supports("avx2");
#else
    constexpr bool avx2 = false;
#endif
    for (int32_t done = 0; done < length; done += kChunk) {
        const int32_t n = std::min(kChunk, length - done);
        inverse.row(first + done + 0.5, k + 0.5, n, u, v);
#if defined(__x86_64__)
        if (avx2 && n >= 4) {
            plan_entries_avx2(u, v, n, m, cell + done, st + done);
            continue;
        }
#endif
        plan_entries(u, v, n, m, cell + done, st + done);
    }
}

}  // namespace

RenderPlan plan_render(const Hierarchy& h, std::span<const Vec2> mesh_vertices, double W, double H,
                       int width, int height, const RenderOptions& options) {
    const int level = options.level < 0 ? h.finest() : options.level;
    if (level < 1 || level > h.finest()) {
        throw Error(str("render: level ", level, " is outside 1..", h.finest()));
    }
    if (width < 1 || height < 1 || int64_t{width} * height > 400'000'000) {
        throw Error(str("render: output size ", width, "x", height, " is out of range"));
    }
    const LevelTopology& t = h.levels[level];
    const int32_t m = t.patch_cells;
    const double sx = width / W, sy = height / H;
    std::vector<Quad> quads = t1_quads(h, mesh_vertices);
    RenderPlan plan;
    plan.width = width;
    plan.height = height;
    plan.level = level;
    plan.samples = t.n_vertices;
    plan.cells = m;
    // Sized without zeroing and copied on all cores (7 MB at density 2 on 1280x720).
    plan.grid.resize(t.patch_grid.size());
    parallel_for(
        static_cast<int64_t>(t.patch_grid.size()),
        [&](int64_t begin, int64_t end) {
            std::copy(t.patch_grid.begin() + begin, t.patch_grid.begin() + end,
                      plan.grid.begin() + begin);
        },
        1 << 18);
    // Two passes over the quads, each shared among the cores: the first counts each quad's row
    // runs and pixels, the second (at the places the counts give) finds the runs again and
    // writes them with their pixels' entries (the inverse bilinear maps: the cost).
    const int64_t count = static_cast<int64_t>(quads.size());
    std::vector<int32_t> first_row(quads.size()), last_row(quads.size());
    for (size_t qi = 0; qi < quads.size(); ++qi) {
        Quad& q = quads[qi];
        for (Vec2& c : q) c = {c.x * sx, c.y * sy};
        double y0 = q[0].y, y1 = q[0].y;
        for (const Vec2& c : q) y0 = std::min(y0, c.y), y1 = std::max(y1, c.y);
        first_row[qi] = std::max(0, static_cast<int>(std::ceil(y0 - 0.5)));
        last_row[qi] = std::min(height, static_cast<int>(std::ceil(y1 - 0.5)));
    }
    // f(k, first, last) for each row k of quad qi with pixel centres in it, columns [first, last).
    const auto for_each_run = [&](int64_t qi, auto&& f) {
        for (int k = first_row[qi]; k < last_row[qi]; ++k) {
            int first, last;
            if (!row_span(quads[qi], k + 0.5, first, last)) continue;
            first = std::max(first, 0);
            last = std::min(last, width);
            if (last > first) f(k, first, last);
        }
    };
    std::vector<int32_t> runs_of(quads.size()), pixels_of(quads.size());
    parallel_for(
        count,
        [&](int64_t begin, int64_t end) {
            for (int64_t qi = begin; qi < end; ++qi) {
                int32_t runs = 0, pixels = 0;
                for_each_run(qi, [&](int, int first, int last) { ++runs, pixels += last - first; });
                runs_of[qi] = runs;
                pixels_of[qi] = pixels;
            }
        },
        64);
    plan.quad_runs.assign(quads.size() + 1, 0);
    std::vector<size_t> first_entry(quads.size() + 1, 0);
    for (size_t qi = 0; qi < quads.size(); ++qi) {
        plan.quad_runs[qi + 1] = plan.quad_runs[qi] + runs_of[qi];
        first_entry[qi + 1] = first_entry[qi] + static_cast<size_t>(pixels_of[qi]);
    }
    plan.run_start.resize(static_cast<size_t>(plan.quad_runs.back()));
    plan.run_length.resize(plan.run_start.size());
    plan.cell.resize(first_entry.back());  // every entry is written below: not zeroed first
    plan.st.resize(first_entry.back());
    parallel_for(
        count,
        [&](int64_t begin, int64_t end) {
            for (int64_t qi = begin; qi < end; ++qi) {
                const QuadInverse inverse(quads[qi]);
                int32_t run = plan.quad_runs[qi];
                size_t e = first_entry[qi];
                for_each_run(qi, [&](int k, int first, int last) {
                    plan.run_start[run] = k * width + first;
                    plan.run_length[run] = last - first;
                    plan_run(inverse, first, last - first, k, m, plan.cell.data() + e,
                             plan.st.data() + e);
                    ++run;
                    e += static_cast<size_t>(last - first);
                });
            }
        },
        16);
    return plan;
}

Image render(const RenderPlan& plan, std::span<const std::span<const float>> planes,
             SampleFormat format) {
    Image out = make_image(plan.width, plan.height, static_cast<int>(planes.size()), format);
    render_into(plan, planes, out);
    return out;
}

std::vector<size_t> plan_entry_starts(const RenderPlan& plan) {
    const size_t quads = plan.quad_runs.size() - 1;
    std::vector<size_t> starts(quads + 1, 0);
    for (size_t q = 0; q < quads; ++q) {
        starts[q + 1] = starts[q];
        for (int32_t run = plan.quad_runs[q]; run < plan.quad_runs[q + 1]; ++run) {
            starts[q + 1] += static_cast<size_t>(plan.run_length[run]);
        }
    }
    return starts;
}

void check_render_planes(const RenderPlan& plan, std::span<const std::span<const float>> planes,
                         int count) {
    if (count > 0 && planes.size() != static_cast<size_t>(count)) {
        throw Error(str("render: ", planes.size(), " planes where ", count, " are rendered"));
    }
    for (size_t c = 0; c < planes.size(); ++c) {
        if (planes[c].size() < static_cast<size_t>(plan.samples)) {
            throw Error(str("render: plane ", c, " has ", planes[c].size(), " values, level ",
                            plan.level, " has ", plan.samples, " samples"));
        }
    }
}

void render_into(const RenderPlan& plan, std::span<const std::span<const float>> planes,
                 Image& out) {
    if (out.width != plan.width || out.height != plan.height ||
        out.planes.size() != planes.size()) {
        throw Error(str("render: output image is ", out.width, "x", out.height, " with ",
                        out.planes.size(), " planes; the plan is ", plan.width, "x", plan.height,
                        " for ", planes.size(), " planes"));
    }
    const size_t channels = planes.size();
    const std::vector<float*> outs = plane_pointers(out);
    with_channel_count(static_cast<int>(channels), [&]<int C>() {
        render_each<C>(plan, planes, [&](int32_t pixel, const float* values) {
            for (size_t c = 0; c < (C > 0 ? static_cast<size_t>(C) : channels); ++c)
                outs[c][pixel] = values[c];
        });
    });
}

}  // namespace tesswave
