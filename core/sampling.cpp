#include "sampling.h"

#include <algorithm>
#include <cmath>

#include "error.h"
#include "mesh.h"
#include "parametrization.h"
#include "strings.h"

namespace tesswave {
namespace {

// One channel's bilinear lookup at (x, y) in level-0 pixel units on a plane of w x h pixels that
// each cover `size` level-0 pixels.
float lookup(const float* plane, int w, int h, double size, double x, double y) {
    const double fx = std::clamp(x / size - 0.5, 0.0, w - 1.0);
    const double fy = std::clamp(y / size - 0.5, 0.0, h - 1.0);
    const int x0 = std::min(static_cast<int>(fx), std::max(w - 2, 0));
    const int y0 = std::min(static_cast<int>(fy), std::max(h - 2, 0));
    const int x1 = std::min(x0 + 1, w - 1), y1 = std::min(y0 + 1, h - 1);
    const float tx = static_cast<float>(fx - x0), ty = static_cast<float>(fy - y0);
    const float a = plane[static_cast<size_t>(y0) * w + x0],
                b = plane[static_cast<size_t>(y0) * w + x1];
    const float c = plane[static_cast<size_t>(y1) * w + x0],
                d = plane[static_cast<size_t>(y1) * w + x1];
    const float top = a + (b - a) * tx, bottom = c + (d - c) * tx;
    return top + (bottom - top) * ty;
}

// 2x2 box averages down to 1x1; the last row or column of an odd size is repeated.
std::vector<Image> mip_pyramid(const Image& image) {
    std::vector<Image> levels{image};
    while (levels.back().width > 1 || levels.back().height > 1) {
        const Image& src = levels.back();
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
        levels.push_back(std::move(dst));
    }
    return levels;
}

// Per sample of the level: the side in pixels of the cells around it, from the area of the T1
// quad it lies in divided by its m x m cells.
std::vector<float> footprints(const Hierarchy& h, std::span<const Vec2> mesh_vertices, int level) {
    const LevelTopology& t = h.levels[level];
    const int32_t m = t.patch_cells, side = m + 1;
    const std::vector<Quad> quads = t1_quads(h, mesh_vertices);
    std::vector<float> out(t.n_vertices, 0.0f);
    for (size_t p = 0; p < quads.size(); ++p) {
        const float f = static_cast<float>(std::sqrt(std::abs(signed_area(quads[p]))) / m);
        const int32_t* grid = &t.patch_grid[p * side * side];
        for (int32_t k = 0; k < side * side; ++k) out[grid[k]] = std::max(out[grid[k]], f);
    }
    return out;
}

}  // namespace

std::vector<std::vector<float>> sample_bilinear(const Image& image,
                                                std::span<const Vec2> positions) {
    std::vector<std::vector<float>> out(image.channels(), std::vector<float>(positions.size()));
    for (int c = 0; c < image.channels(); ++c) {
        const float* plane = image.planes[c].data();
        for (size_t i = 0; i < positions.size(); ++i) {
            out[c][i] =
                lookup(plane, image.width, image.height, 1.0, positions[i].x, positions[i].y);
        }
    }
    return out;
}

std::vector<std::vector<float>> sample_image(const Image& image, const Hierarchy& h,
                                             std::span<const Vec2> mesh_vertices,
                                             const SampleOptions& options) {
    const int level = options.level < 0 ? h.finest() : options.level;
    if (level < 1 || level > h.finest()) {
        throw Error(str("sampling: level ", level, " is outside 1..", h.finest()));
    }
    const std::vector<Vec2> positions = refine_positions(h, mesh_vertices, level);
    if (!options.prefilter) return sample_bilinear(image, positions);
    const std::vector<float> size = footprints(h, mesh_vertices, level);
    const float largest = *std::max_element(size.begin(), size.end());
    if (largest <= 1.0f) return sample_bilinear(image, positions);
    const std::vector<Image> mips = mip_pyramid(image);
    const int top = static_cast<int>(mips.size()) - 1;
    std::vector<std::vector<float>> out(image.channels(), std::vector<float>(positions.size()));
    for (size_t i = 0; i < positions.size(); ++i) {
        const double lod = std::clamp(double{std::log2(std::max(1.0f, size[i]))}, 0.0, double(top));
        const int l0 = std::min(static_cast<int>(lod), top), l1 = std::min(l0 + 1, top);
        const float w1 = static_cast<float>(lod - l0);
        for (int c = 0; c < image.channels(); ++c) {
            const Image& a = mips[l0];
            const Image& b = mips[l1];
            const float va = lookup(a.planes[c].data(), a.width, a.height, std::ldexp(1.0, l0),
                                    positions[i].x, positions[i].y);
            const float vb = w1 == 0 ? va
                                     : lookup(b.planes[c].data(), b.width, b.height,
                                              std::ldexp(1.0, l1), positions[i].x, positions[i].y);
            out[c][i] = va + (vb - va) * w1;
        }
    }
    return out;
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

}  // namespace tesswave
