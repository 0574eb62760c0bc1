#include "core/math/render.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "core/math/error.h"
#include "core/math/parallel.h"
#include "core/math/parametrization.h"
#include "core/math/strings.h"

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

// The plan entries of one row run of a quad: each pixel's grid cell and fractions, from the
// quad's inverse bilinear map (QuadInverse::row, four pixels at a time) in chunks on the stack.
void plan_run(const QuadInverse& inverse, int32_t first, int32_t length, int32_t k, int32_t m,
              int32_t* cell, std::array<uint16_t, 2>* st) {
    constexpr int32_t kChunk = 64;
    double u[kChunk], v[kChunk];
    const int32_t side = m + 1;
    for (int32_t done = 0; done < length; done += kChunk) {
        const int32_t n = std::min(kChunk, length - done);
        inverse.row(first + done + 0.5, k + 0.5, n, u, v);
        for (int32_t j = 0; j < n; ++j) {
            // A degenerate quad can leave u outside [0, 1] (QuadInverse keeps the raw root when no
            // root scores): clamped, so that the cell and the fractions stay in range.
            const double s = std::clamp(u[j], 0.0, 1.0) * m, r = std::clamp(v[j], 0.0, 1.0) * m;
            const int32_t c0 = std::min(static_cast<int32_t>(s), m - 1);
            const int32_t r0 = std::min(static_cast<int32_t>(r), m - 1);
            cell[done + j] = r0 * side + c0;
            st[done + j] = {fixed16(s - c0), fixed16(r - r0)};
        }
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
    plan.grid.assign(t.patch_grid.begin(), t.patch_grid.end());
    // First the runs of every quad (cheap, in order), then each quad's pixels at their known
    // place in the plan (the inverse bilinear maps: the cost), quads shared among the cores.
    plan.quad_runs.push_back(0);
    std::vector<size_t> first_entry = {0};
    for (Quad& q : quads) {
        for (Vec2& c : q) c = {c.x * sx, c.y * sy};
        double y0 = q[0].y, y1 = q[0].y;
        for (const Vec2& c : q) y0 = std::min(y0, c.y), y1 = std::max(y1, c.y);
        const int k0 = std::max(0, static_cast<int>(std::ceil(y0 - 0.5)));
        const int k1 = std::min(height, static_cast<int>(std::ceil(y1 - 0.5)));
        size_t entries = first_entry.back();
        for (int k = k0; k < k1; ++k) {
            int first, last;
            if (!row_span(q, k + 0.5, first, last)) continue;
            first = std::max(first, 0);
            last = std::min(last, width);
            if (last <= first) continue;
            plan.run_start.push_back(k * width + first);
            plan.run_length.push_back(last - first);
            entries += last - first;
        }
        plan.quad_runs.push_back(static_cast<int32_t>(plan.run_start.size()));
        first_entry.push_back(entries);
    }
    plan.cell.resize(first_entry.back());
    plan.st.resize(first_entry.back());
    parallel_for(
        static_cast<int64_t>(quads.size()),
        [&](int64_t begin, int64_t end) {
            for (int64_t qi = begin; qi < end; ++qi) {
                const QuadInverse inverse(quads[qi]);
                size_t e = first_entry[qi];
                for (int32_t run = plan.quad_runs[qi]; run < plan.quad_runs[qi + 1]; ++run) {
                    const int32_t k = plan.run_start[run] / width;
                    const int32_t first = plan.run_start[run] % width;
                    plan_run(inverse, first, plan.run_length[run], k, m, plan.cell.data() + e,
                             plan.st.data() + e);
                    e += static_cast<size_t>(plan.run_length[run]);
                }
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
