#include "core/math/sampling.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "core/math/error.h"
#include "core/math/mesh.h"
#include "core/math/parallel.h"
#include "core/math/parametrization.h"
#include "core/math/strings.h"

#if defined(__x86_64__)
#include "core/math/bilinear4.h"
#endif

namespace tesswave {
namespace {

// 2x2 box averages of `src`; the last row or column of an odd size is repeated. Rows are shared
// among the cores.
Image half_size(const Image& src) {
    const int w = (src.width + 1) / 2, h = (src.height + 1) / 2;
    Image dst = make_image(w, h, src.channels(), src.format);
    parallel_for(int64_t{h}, [&](int64_t begin, int64_t end) {
        for (int c = 0; c < src.channels(); ++c) {
            for (auto y = static_cast<int>(begin); y < end; ++y) {
                const int ya = 2 * y, yb = std::min(2 * y + 1, src.height - 1);
                const float* a = src.planes[c].data() + static_cast<size_t>(ya) * src.width;
                const float* b = src.planes[c].data() + static_cast<size_t>(yb) * src.width;
                float* out = dst.planes[c].data() + static_cast<size_t>(y) * w;
                const int pairs = src.width / 2;  // the columns with a right neighbour
                for (int x = 0; x < pairs; ++x) {
                    out[x] = 0.25f * (a[2 * x] + a[2 * x + 1] + b[2 * x] + b[2 * x + 1]);
                }
                if (pairs < w) {
                    const int xa = src.width - 1;
                    out[pairs] = 0.25f * (a[xa] + a[xa] + b[xa] + b[xa]);
                }
            }
        }
    });
    return dst;
}

// The pyramid level (fractional: trilinear) that samples cells of `size` pixels (the side of a
// square of the cell's area), at most `top`: log2 of the size, except that cells up to kNoBlend
// pixels read the image alone, and the blend with level 1 rises from 0 there to 1 at 2 pixels
// (continuous). The default grid of a 1280x720 image has cells of 1 x 1.023 pixels (size 1.011):
// with log2 of the size it built a pyramid and read two levels per sample to blend in 1.6 % of
// the 2x2 averages; cells of 1.07 would have blended in 9.8 %.
constexpr double kNoBlend = 1.07;
double pyramid_level(double size, int top) {
    const double lod = std::log2(std::max(1.0, size));
    if (lod >= 1) return std::min(lod, double(top));
    const double from = std::log2(kNoBlend);
    return lod <= from ? 0.0 : std::min((lod - from) / (1 - from), double(top));
}

#if defined(__x86_64__)
// One pyramid level as the vector kernels read it: an image at least 2x2 pixels, so that a tap's
// right and lower pixels are the next ones (x1 = x0 + 1, y1 = y0 + 1), whose pixel count fits
// int32 (the caller checks), and its scale 2^-level.
struct Level4 {
    const Image* image;
    double inv_size;
};

// The taps of four nodes at (px, py) on a level, as bilinear_tap makes them.
[[gnu::target("avx2"), gnu::always_inline]] inline detail::Taps4 taps4(const Level4& level,
                                                                       __m256d px, __m256d py) {
    const Image& image = *level.image;
    const __m256d inv = _mm256_set1_pd(level.inv_size), half = _mm256_set1_pd(0.5);
    const __m256d zero = _mm256_setzero_pd();
    const __m256d fx =
        _mm256_min_pd(_mm256_set1_pd(image.width - 1.0),
                      _mm256_max_pd(zero, _mm256_sub_pd(_mm256_mul_pd(px, inv), half)));
    const __m256d fy =
        _mm256_min_pd(_mm256_set1_pd(image.height - 1.0),
                      _mm256_max_pd(zero, _mm256_sub_pd(_mm256_mul_pd(py, inv), half)));
    const __m128i x0 = _mm_min_epi32(_mm256_cvttpd_epi32(fx), _mm_set1_epi32(image.width - 2));
    const __m128i y0 = _mm_min_epi32(_mm256_cvttpd_epi32(fy), _mm_set1_epi32(image.height - 2));
    const __m128 tx = _mm256_cvtpd_ps(_mm256_sub_pd(fx, _mm256_cvtepi32_pd(x0)));
    const __m128 ty = _mm256_cvtpd_ps(_mm256_sub_pd(fy, _mm256_cvtepi32_pd(y0)));
    return detail::taps4(x0, y0, image.width, tx, ty);
}

// Four nodes at (px, py), read from `a`, or from `a` and `b` blended by w1 when Blend, written to
// out[ch][ids[k]]: the taps of bilinear_tap, read as bilinear_at reads them and blended as the
// scalar nodes are, the same operations in the same order (the clamps as std::clamp compares), so
// the same bits.
template <bool Blend>
[[gnu::target("avx2"), gnu::always_inline]] inline void sample4(const Level4& a, const Level4& b,
                                                                __m128 w1, __m256d px, __m256d py,
                                                                const int32_t* ids,
                                                                float* const* out, int channels) {
    const detail::Taps4 ta = taps4(a, px, py);
    detail::Taps4 tb{};
    if constexpr (Blend) tb = taps4(b, px, py);
    for (int ch = 0; ch < channels; ++ch) {
        __m128 v = detail::bilinear4(a.image->planes[ch].data(), ta);
        if constexpr (Blend) {
            const __m128 vb = detail::bilinear4(b.image->planes[ch].data(), tb);
            v = _mm_add_ps(v, _mm_mul_ps(_mm_sub_ps(vb, v), w1));
        }
        alignas(16) float values[4];
        _mm_store_ps(values, v);
        float* to_plane = out[ch];
        for (int k = 0; k < 4; ++k) to_plane[ids[k]] = values[k];
    }
}

// Grid nodes c in [from, to) of one row of a quad, at lerp(left, right, t[c]) as lerp computes
// it, four at a time. The last four may overlap the four before: those nodes get the same values
// again. Needs at least four nodes.
template <bool Blend>
[[gnu::target("avx2")]] void sample_row_avx2(const Level4& a, const Level4& b, float w1, Vec2 left,
                                             Vec2 right, const double* t, int32_t from, int32_t to,
                                             const int32_t* ids, float* const* out, int channels) {
    const __m256d lx = _mm256_set1_pd(left.x), dx = _mm256_set1_pd(right.x - left.x);
    const __m256d ly = _mm256_set1_pd(left.y), dy = _mm256_set1_pd(right.y - left.y);
    const __m128 weight = _mm_set1_ps(w1);
    for (int32_t next = from; next < to; next += 4) {
        const int32_t c = std::min(next, to - 4);
        const __m256d tc = _mm256_loadu_pd(t + c);
        sample4<Blend>(a, b, weight, _mm256_add_pd(lx, _mm256_mul_pd(tc, dx)),
                       _mm256_add_pd(ly, _mm256_mul_pd(tc, dy)), ids + c, out, channels);
    }
}

// Nodes k in [0, n) at (x[k], y[k]), four at a time, the last four overlapping; n >= 4.
template <bool Blend>
[[gnu::target("avx2")]] void sample_list_avx2(const Level4& a, const Level4& b, float w1,
                                              const double* x, const double* y, const int32_t* ids,
                                              int32_t n, float* const* out, int channels) {
    const __m128 weight = _mm_set1_ps(w1);
    for (int32_t next = 0; next < n; next += 4) {
        const int32_t k = std::min(next, n - 4);
        sample4<Blend>(a, b, weight, _mm256_loadu_pd(x + k), _mm256_loadu_pd(y + k), ids + k, out,
                       channels);
    }
}
#endif

}  // namespace

namespace {

// Positions [begin, end) of sample_bilinear: C channels (0: any count). A fixed count keeps the
// plane pointers in registers and unrolls the channel loop; the arithmetic is the same.
template <int C>
void sample_positions(const Image& image, std::span<const Vec2> positions,
                      std::vector<std::vector<float>>& out, int64_t begin, int64_t end) {
    const int channels = C > 0 ? C : image.channels();
    std::array<const float*, 4> in{};
    std::array<float*, 4> to{};
    if constexpr (C > 0) {
        for (int c = 0; c < C; ++c) in[c] = image.planes[c].data(), to[c] = out[c].data();
    }
    const int w = image.width, h = image.height;
    for (int64_t i = begin; i < end; ++i) {
        const Tap t = bilinear_tap(w, h, 1.0, positions[i]);  // level 0
        for (int c = 0; c < channels; ++c) {
            if constexpr (C > 0) {
                to[c][i] = bilinear_at(t, in[c]);
            } else {
                out[c][i] = bilinear_at(t, image.planes[c].data());
            }
        }
    }
}

}  // namespace

std::vector<std::vector<float>> sample_bilinear(const Image& image,
                                                std::span<const Vec2> positions) {
    std::vector<std::vector<float>> out(image.channels(), std::vector<float>(positions.size()));
    parallel_for(
        static_cast<int64_t>(positions.size()),
        [&](int64_t begin, int64_t end) {
            with_channel_count(image.channels(), [&]<int C>() {
                sample_positions<C>(image, positions, out, begin, end);
            });
        },
        4096);
    return out;
}

std::vector<std::vector<float>> sample_image(const Image& image, const Hierarchy& h,
                                             std::span<const Vec2> mesh_vertices,
                                             const SampleOptions& options) {
    const int level = options.level < 0 ? h.finest() : options.level;
    if (level < 1 || level > h.finest()) {
        throw Error(str("sampling: level ", level, " is outside 1..", h.finest()));
    }
    std::vector<std::vector<float>> out(image.channels(),
                                        std::vector<float>(h.levels[level].n_vertices));
    const std::vector<std::span<float>> spans(out.begin(), out.end());
    sample_image_into(image, h, mesh_vertices, spans, options);
    return out;
}

std::vector<uint8_t> quad_border_ownership(const Hierarchy& h) {
    if (h.finest() < 1) return {};
    const LevelTopology& t1 = h.levels[1];
    if (!t1.topology)
        throw Error("sampling: T1 has no topology");  // only T_J from J = 2 may lack it
    std::vector<uint8_t> owns(static_cast<size_t>(t1.num_faces()), 0);
    for (int32_t p = 0; p < t1.num_faces(); ++p) {
        for (int s = 0; s < 4; ++s) {
            // Side s runs from corner s to corner s + 1: the quads on both sides of that T1 edge
            // hold its inner nodes, and every quad around a corner holds the corner.
            const std::array<int32_t, 2>& faces = t1.edge_f[t1.face_e[4 * p + s]];
            if (std::max(faces[0], faces[1]) == p) owns[p] |= uint8_t{1} << s;
            const int32_t v = t1.face_v[4 * p + s];
            int32_t last = -1;
            for (int32_t i = t1.star_f_offsets[v]; i < t1.star_f_offsets[v + 1]; ++i)
                last = std::max(last, t1.star_f[i]);
            if (last == p) owns[p] |= uint8_t{16} << s;
        }
    }
    return owns;
}

void sample_image_into(const Image& image, const Hierarchy& h, std::span<const Vec2> mesh_vertices,
                       std::span<const std::span<float>> out, const SampleOptions& options) {
    const int level = options.level < 0 ? h.finest() : options.level;
    if (level < 1 || level > h.finest()) {
        throw Error(str("sampling: level ", level, " is outside 1..", h.finest()));
    }
    const LevelTopology& t = h.levels[level];
    const int channels = image.channels();
    if (out.size() != static_cast<size_t>(channels)) {
        throw Error(str("sampling: ", out.size(), " output planes for ", channels, " channels"));
    }
    for (auto plane : out) {
        if (plane.size() != static_cast<size_t>(t.n_vertices)) {
            throw Error(str("sampling: an output plane has ", plane.size(), " values, level ",
                            level, " has ", t.n_vertices, " samples"));
        }
    }
    const int32_t m = t.patch_cells, side = m + 1;
    const std::vector<Quad> quads = t1_quads(h, mesh_vertices);
    // Pyramid levels are built only as deep as the largest cells need (none when every cell is
    // at most a pixel); level 0 is the image itself.
    double largest = 0;
    for (const Quad& q : quads)
        largest = std::max(largest, std::sqrt(std::abs(signed_area(q))) / m);
    std::vector<Image> mips;
    const Image* level0 = &image;
    if (options.prefilter && largest > kNoBlend) {
        const int needed = static_cast<int>(std::ceil(std::log2(largest)));
        for (int l = 0; l < needed && (mips.empty() ? image : mips.back()).width > 1; ++l) {
            mips.push_back(half_size(mips.empty() ? image : mips.back()));
        }
    }
    auto pyramid = [&](int l) -> const Image& { return l == 0 ? *level0 : mips[l - 1]; };
    const int top = static_cast<int>(mips.size());
    // A sample on a quad's border belongs to several quads, which may read it at other pyramid
    // levels: the last quad in order that holds it writes it, whatever the thread count.
    const std::vector<uint8_t> owns = quad_border_ownership(h);
    std::vector<double> along(static_cast<size_t>(side));  // grid column c at c/m of a row
    for (int32_t c = 0; c <= m; ++c) along[c] = double(c) / m;
    std::vector<float*> planes(out.size());
    for (size_t ch = 0; ch < out.size(); ++ch) planes[ch] = out[ch].data();
#if defined(__x86_64__)
    // The vector rows index pixels with int32.
    static const bool has_avx2 = __builtin_cpu_supports("avx2");
    const bool avx2 =
        options.vector && has_avx2 && int64_t{image.width} * image.height <= INT32_MAX;
#endif
    // Quad by quad along its grid rows, so that image reads stay local. Grid node (r, c) is the
    // bilinear map at (c/m, r/m): the position refinement gives it (DESIGN.md 2.2). `edge` holds a
    // quad's border nodes that it writes, for the vector kernel (one list per piece of quads).
    struct Nodes {
        std::vector<double> x, y;
        std::vector<int32_t> ids;
    };
    const auto sample_quad = [&](size_t p, [[maybe_unused]] Nodes& edge) {
        const Quad& q = quads[p];
        const double size = std::sqrt(std::abs(signed_area(q))) / m;
        const double lod = top == 0 ? 0.0 : pyramid_level(size, top);
        const int l0 = static_cast<int>(lod), l1 = std::min(l0 + 1, top);
        const float w1 = static_cast<float>(lod - l0);
        const Image& a = pyramid(l0);
        const Image& b = pyramid(l1);
        const double inv_a = std::ldexp(1.0, -l0), inv_b = std::ldexp(1.0, -l1);
        const int32_t* grid = &t.patch_grid[p * side * side];
        const auto write = [&](Vec2 pos, int32_t id) {
            const Tap ta = bilinear_tap(a.width, a.height, inv_a, pos);
            if (w1 == 0) {
                for (int ch = 0; ch < channels; ++ch)
                    out[ch][id] = bilinear_at(ta, a.planes[ch].data());
            } else {
                const Tap tb = bilinear_tap(b.width, b.height, inv_b, pos);
                for (int ch = 0; ch < channels; ++ch) {
                    const float va = bilinear_at(ta, a.planes[ch].data());
                    out[ch][id] = va + (bilinear_at(tb, b.planes[ch].data()) - va) * w1;
                }
            }
        };
#if defined(__x86_64__)
        // Four nodes at a time: each row's inner nodes (a border row's only when the quad owns
        // that side), then the border nodes the quad owns, as one list.
        if (avx2 && std::min({a.width, a.height, b.width, b.height}) >= 2) {
            const Level4 la{&a, inv_a}, lb{&b, inv_b};
            const bool blend = w1 != 0;
            edge.x.clear(), edge.y.clear(), edge.ids.clear();
            const auto list = [&](int32_t r, int32_t c, Vec2 left, Vec2 right) {
                const Vec2 pos = lerp(left, right, along[c]);
                edge.x.push_back(pos.x), edge.y.push_back(pos.y);
                edge.ids.push_back(grid[r * side + c]);
            };
            for (int32_t r = 0; r <= m; ++r) {
                const Vec2 left = lerp(q[0], q[3], double(r) / m);
                const Vec2 right = lerp(q[1], q[2], double(r) / m);
                for (const int32_t c : {int32_t{0}, m}) {
                    if (owns[p] & border_bit(r, c, m)) list(r, c, left, right);
                }
                if ((r == 0 || r == m) && !(owns[p] & border_bit(r, 1, m))) continue;
                if (m - 1 < 4) {
                    for (int32_t c = 1; c < m; ++c) list(r, c, left, right);
                } else if (blend) {
                    sample_row_avx2<true>(la, lb, w1, left, right, along.data(), 1, m,
                                          grid + r * side, planes.data(), channels);
                } else {
                    sample_row_avx2<false>(la, lb, w1, left, right, along.data(), 1, m,
                                           grid + r * side, planes.data(), channels);
                }
            }
            const auto n = static_cast<int32_t>(edge.ids.size());
            if (n < 4) {
                for (int32_t k = 0; k < n; ++k) write({edge.x[k], edge.y[k]}, edge.ids[k]);
            } else if (blend) {
                sample_list_avx2<true>(la, lb, w1, edge.x.data(), edge.y.data(), edge.ids.data(), n,
                                       planes.data(), channels);
            } else {
                sample_list_avx2<false>(la, lb, w1, edge.x.data(), edge.y.data(), edge.ids.data(),
                                        n, planes.data(), channels);
            }
            return;
        }
#endif
        for (int32_t r = 0; r <= m; ++r) {
            const Vec2 left = lerp(q[0], q[3], double(r) / m);
            const Vec2 right = lerp(q[1], q[2], double(r) / m);
            const bool border_row = r == 0 || r == m;
            for (int32_t c = 0; c <= m; ++c) {
                if ((border_row || c == 0 || c == m) && !(owns[p] & border_bit(r, c, m))) continue;
                write(lerp(left, right, along[c]), grid[r * side + c]);
            }
        }
    };
    parallel_for(static_cast<int64_t>(quads.size()), [&](int64_t begin, int64_t end) {
        Nodes edge;
        for (int64_t p = begin; p < end; ++p) sample_quad(static_cast<size_t>(p), edge);
    });
}

int level_for_density(const Mesh& mesh, int pixels, double density, int max_level) {
    if (!(density > 0) || !std::isfinite(density)) {
        throw Error(str("density: ", density, " must be a positive number of samples per pixel"));
    }
    const auto counts = level_counts(mesh, max_level);
    int best = 1;
    double best_gap = INFINITY;
    for (int j = 1; j <= max_level; ++j) {
        const double gap = std::abs(std::log(counts[j].vertices / (density * pixels)));
        if (gap < best_gap) best = j, best_gap = gap;
    }
    return best;
}

DefaultGrid default_grid(int width, int height, double density, int levels) {
    if (!(density > 0) || !std::isfinite(density)) {
        throw Error(str("density: ", density, " must be a positive number of samples per pixel"));
    }
    const double root = std::sqrt(density);
    const double short_side = std::min(width, height) * root;
    DefaultGrid g;
    g.levels = levels > 0
                   ? levels
                   : std::clamp(static_cast<int>(std::floor(std::log2(short_side))) - 3, 1, 7);
    const double cell = std::ldexp(1.0, g.levels) / root;  // pixels per T0 cell side
    g.cols = std::max(1, static_cast<int>(std::lround(width / cell)));
    g.rows = std::max(1, static_cast<int>(std::lround(height / cell)));
    return g;
}

}  // namespace tesswave
