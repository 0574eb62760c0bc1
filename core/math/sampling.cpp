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

// 2x2 box averages of `src`; the last row or column of an odd size is repeated.
Image half_size(const Image& src) {
    const int w = (src.width + 1) / 2, h = (src.height + 1) / 2;
    Image dst = make_image(w, h, src.channels(), src.format);
    for (int c = 0; c < src.channels(); ++c) {
        for (int y = 0; y < h; ++y) {
            const int ya = 2 * y, yb = std::min(2 * y + 1, src.height - 1);
            for (int x = 0; x < w; ++x) {
                const int xa = 2 * x, xb = std::min(2 * x + 1, src.width - 1);
                dst.at(c, x, y) = 0.25f * (src.at(c, xa, ya) + src.at(c, xb, ya) +
                                           src.at(c, xa, yb) + src.at(c, xb, yb));
            }
        }
    }
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
// Grid nodes c in [from, to) of one row of a quad, four at a time, read from `image` alone (no
// pyramid blend): the node at lerp(left, right, t[c]), as bilinear_tap and bilinear_at read it,
// the same operations in the same order (the clamps as std::clamp compares), so the same bits.
// The image is at least 2x2 pixels, so that a node's right and lower pixels are the next ones (x1 =
// x0 + 1, y1 = y0 + 1), and its pixel count fits int32 (the caller checks). Returns how many nodes
// it did: all of them, or none when there are fewer than four.
[[gnu::target("avx2")]] int32_t sample_row_avx2(const Image& image, double inv_size, Vec2 left,
                                                Vec2 right, const double* t, int32_t from,
                                                int32_t to, const int32_t* ids, float* const* out) {
    const int w = image.width, h = image.height;
    const __m256d lx = _mm256_set1_pd(left.x), dx = _mm256_set1_pd(right.x - left.x);
    const __m256d ly = _mm256_set1_pd(left.y), dy = _mm256_set1_pd(right.y - left.y);
    const __m256d inv = _mm256_set1_pd(inv_size), half = _mm256_set1_pd(0.5);
    const __m256d zero = _mm256_setzero_pd();
    const __m256d x_hi = _mm256_set1_pd(w - 1.0), y_hi = _mm256_set1_pd(h - 1.0);
    const __m128i x0_hi = _mm_set1_epi32(std::max(w - 2, 0)),
                  y0_hi = _mm_set1_epi32(std::max(h - 2, 0));
    const int channels = image.channels();
    if (to - from < 4) return 0;
    for (int32_t next = from; next < to; next += 4) {
        // The last four may overlap the four before: those nodes get the same values again.
        const int32_t c = std::min(next, to - 4);
        const __m256d tc = _mm256_loadu_pd(t + c);
        const __m256d px = _mm256_add_pd(lx, _mm256_mul_pd(tc, dx));
        const __m256d py = _mm256_add_pd(ly, _mm256_mul_pd(tc, dy));
        const __m256d fx =
            _mm256_min_pd(x_hi, _mm256_max_pd(zero, _mm256_sub_pd(_mm256_mul_pd(px, inv), half)));
        const __m256d fy =
            _mm256_min_pd(y_hi, _mm256_max_pd(zero, _mm256_sub_pd(_mm256_mul_pd(py, inv), half)));
        const __m128i x0 = _mm_min_epi32(_mm256_cvttpd_epi32(fx), x0_hi);
        const __m128i y0 = _mm_min_epi32(_mm256_cvttpd_epi32(fy), y0_hi);
        const __m128 tx = _mm256_cvtpd_ps(_mm256_sub_pd(fx, _mm256_cvtepi32_pd(x0)));
        const __m128 ty = _mm256_cvtpd_ps(_mm256_sub_pd(fy, _mm256_cvtepi32_pd(y0)));
        const detail::Taps4 taps = detail::taps4(x0, y0, w, tx, ty);
        for (int ch = 0; ch < channels; ++ch) {
            alignas(16) float v[4];
            _mm_store_ps(v, detail::bilinear4(image.planes[ch].data(), taps));
            float* to_plane = out[ch];
            for (int k = 0; k < 4; ++k) to_plane[ids[c + k]] = v[k];
        }
    }
    return to - from;
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
    const bool avx2 = has_avx2 && int64_t{image.width} * image.height <= INT32_MAX;
#endif
    // Quad by quad along its grid rows, so that image reads stay local. Grid node (r, c) is the
    // bilinear map at (c/m, r/m): the position refinement gives it (DESIGN.md 2.2).
    const auto sample_quad = [&](size_t p) {
        const Quad& q = quads[p];
        const double size = std::sqrt(std::abs(signed_area(q))) / m;
        const double lod = top == 0 ? 0.0 : pyramid_level(size, top);
        const int l0 = static_cast<int>(lod), l1 = std::min(l0 + 1, top);
        const float w1 = static_cast<float>(lod - l0);
        const Image& a = pyramid(l0);
        const Image& b = pyramid(l1);
        const double inv_a = std::ldexp(1.0, -l0), inv_b = std::ldexp(1.0, -l1);
        const int32_t* grid = &t.patch_grid[p * side * side];
        for (int32_t r = 0; r <= m; ++r) {
            const Vec2 left = lerp(q[0], q[3], double(r) / m);
            const Vec2 right = lerp(q[1], q[2], double(r) / m);
            const bool border_row = r == 0 || r == m;
            const int32_t* ids = grid + r * side;
            const auto node = [&](int32_t c) {
                const int32_t id = ids[c];
                if ((border_row || c == 0 || c == m) && !(owns[p] & border_bit(r, c, m))) return;
                const Vec2 pos = lerp(left, right, along[c]);
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
            int32_t c = 0;
#if defined(__x86_64__)
            // A row's inner nodes are the quad's alone (no owner to ask), four at a time.
            if (avx2 && !border_row && w1 == 0 && a.width >= 2 && a.height >= 2) {
                node(0);
                c = 1 +
                    sample_row_avx2(a, inv_a, left, right, along.data(), 1, m, ids, planes.data());
            }
#endif
            for (; c <= m; ++c) node(c);
        }
    };
    parallel_for(static_cast<int64_t>(quads.size()), [&](int64_t begin, int64_t end) {
        for (int64_t p = begin; p < end; ++p) sample_quad(static_cast<size_t>(p));
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
