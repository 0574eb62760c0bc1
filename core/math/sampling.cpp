#include "core/math/sampling.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "core/math/error.h"
#include "core/math/mesh.h"
#include "core/math/parallel.h"
#include "core/math/parametrization.h"
#include "core/math/strings.h"

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
    std::vector<int32_t> owner(static_cast<size_t>(t.n_vertices));
    for (size_t p = 0; p < quads.size(); ++p) {
        const int32_t* grid = &t.patch_grid[p * side * side];
        for (int32_t k = 0; k <= m; ++k) {
            for (int32_t i : {k, m * side + k, k * side, k * side + m}) {
                owner[grid[i]] = static_cast<int32_t>(p);
            }
        }
    }
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
            for (int32_t c = 0; c <= m; ++c) {
                const int32_t id = grid[r * side + c];
                if ((border_row || c == 0 || c == m) && owner[id] != static_cast<int32_t>(p))
                    continue;
                const Vec2 pos = lerp(left, right, double(c) / m);
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
            }
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
