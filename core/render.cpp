#include "render.h"

#include <algorithm>
#include <cmath>

#include "error.h"
#include "parametrization.h"
#include "strings.h"

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
    const int32_t m = t.patch_cells, side = m + 1;
    const double sx = width / W, sy = height / H;
    std::vector<Quad> quads = t1_quads(h, mesh_vertices);
    RenderPlan plan;
    plan.width = width;
    plan.height = height;
    plan.level = level;
    plan.samples = t.n_vertices;
    const size_t pixels = static_cast<size_t>(width) * height;
    plan.ids.assign(pixels, {0, 0, 0, 0});
    plan.st.assign(pixels, {0.0f, 0.0f});
    plan.writes.assign(pixels, 0);
    for (size_t p = 0; p < quads.size(); ++p) {
        Quad q = quads[p];
        for (Vec2& c : q) c = {c.x * sx, c.y * sy};
        double y0 = q[0].y, y1 = q[0].y;
        for (const Vec2& c : q) y0 = std::min(y0, c.y), y1 = std::max(y1, c.y);
        const int k0 = std::max(0, static_cast<int>(std::ceil(y0 - 0.5)));
        const int k1 = std::min(height, static_cast<int>(std::ceil(y1 - 0.5)));
        const int32_t* grid = &t.patch_grid[p * side * side];
        for (int k = k0; k < k1; ++k) {
            int first, last;
            if (!row_span(q, k + 0.5, first, last)) continue;
            first = std::max(first, 0);
            last = std::min(last, width);
            for (int i = first; i < last; ++i) {
                const UV uv = inverse_bilinear(q, {i + 0.5, k + 0.5});
                const double s = uv.u * m, r = uv.v * m;
                const int32_t c0 = std::min(static_cast<int32_t>(s), m - 1);
                const int32_t r0 = std::min(static_cast<int32_t>(r), m - 1);
                const size_t px = static_cast<size_t>(k) * width + i;
                plan.ids[px] = {grid[r0 * side + c0], grid[r0 * side + c0 + 1],
                                grid[(r0 + 1) * side + c0], grid[(r0 + 1) * side + c0 + 1]};
                plan.st[px] = {static_cast<float>(s - c0), static_cast<float>(r - r0)};
                ++plan.writes[px];
            }
        }
    }
    return plan;
}

Image render(const RenderPlan& plan, std::span<const std::span<const float>> planes,
             SampleFormat format) {
    for (size_t c = 0; c < planes.size(); ++c) {
        if (planes[c].size() < static_cast<size_t>(plan.samples)) {
            throw Error(str("render: plane ", c, " has ", planes[c].size(), " values, level ",
                            plan.level, " has ", plan.samples, " samples"));
        }
    }
    Image out = make_image(plan.width, plan.height, static_cast<int>(planes.size()), format);
    const size_t pixels = plan.ids.size();
    for (size_t c = 0; c < planes.size(); ++c) {
        const float* __restrict x = planes[c].data();
        float* __restrict o = out.planes[c].data();
        for (size_t px = 0; px < pixels; ++px) {
            const auto& id = plan.ids[px];
            const float s = plan.st[px][0], r = plan.st[px][1];
            const float top = x[id[0]] + (x[id[1]] - x[id[0]]) * s;
            const float bottom = x[id[2]] + (x[id[3]] - x[id[2]]) * s;
            o[px] = top + (bottom - top) * r;
        }
    }
    return out;
}

}  // namespace tesswave
