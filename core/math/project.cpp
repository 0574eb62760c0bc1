#include "core/math/project.h"

#include <algorithm>
#include <cmath>

#include "core/math/error.h"
#include "core/math/render.h"
#include "core/math/sampling.h"
#include "core/math/strings.h"

namespace tesswave {
namespace {

using Planes = std::vector<std::vector<float>>;

// R^T M R + beta u L as a 3x3 stencil for every node of every quad's (m+1)^2 grid, entry
// (dr + 1) * 3 + (dc + 1) for the neighbour dr rows and dc columns away; a node shared by several
// quads sums their stencils. `diagonal` holds the whole matrix's diagonal, alpha u included.
struct NormalMatrix {
    int32_t side = 0, grid_size = 0;
    size_t quads = 0;
    const int32_t* grid = nullptr;  // the plan's sample ids, grid_size a quad
    std::vector<float> stencil;
    std::vector<double> diagonal;
    double alpha = 0;  // alpha u
};

constexpr int stencil_entry(int dr, int dc) { return (dr + 1) * 3 + (dc + 1); }

// Adds the data term (and the right-hand side R^T M I) of every pixel the plan renders.
void add_data_term(const RenderPlan& plan, const Image& image, NormalMatrix& A, Planes& rhs) {
    const int channels = image.channels();
    constexpr float kUnit = 1.0f / 65536.0f;
    const int dr[4] = {0, 0, 1, 1}, dc[4] = {0, 1, 0, 1};
    const int32_t offset[4] = {0, 1, A.side, A.side + 1};
    size_t i = 0;
    for (size_t q = 0; q < A.quads; ++q) {
        float* st = A.stencil.data() + q * A.grid_size * 9;
        const int32_t* ids = A.grid + q * A.grid_size;
        for (int32_t run = plan.quad_runs[q]; run < plan.quad_runs[q + 1]; ++run) {
            const int32_t start = plan.run_start[run], length = plan.run_length[run];
            for (int32_t n = 0; n < length; ++n, ++i) {
                const size_t px = static_cast<size_t>(start + n);
                bool finite = true;
                for (int c = 0; c < channels; ++c) finite &= std::isfinite(image.planes[c][px]);
                if (!finite) continue;
                const float s = plan.st[i][0] * kUnit, t = plan.st[i][1] * kUnit;
                const float w[4] = {(1 - s) * (1 - t), s * (1 - t), (1 - s) * t, s * t};
                const int32_t cell = plan.cell[i];
                for (int a = 0; a < 4; ++a) {
                    float* row = st + (cell + offset[a]) * 9;
                    for (int b = 0; b < 4; ++b) {
                        row[stencil_entry(dr[b] - dr[a], dc[b] - dc[a])] += w[a] * w[b];
                    }
                    const int32_t id = ids[cell + offset[a]];
                    for (int c = 0; c < channels; ++c) rhs[c][id] += w[a] * image.planes[c][px];
                }
            }
        }
    }
}

// beta u (s_k - s_l)^2 for every edge of every quad's grid.
void add_smoothness(NormalMatrix& A, float weight) {
    if (weight == 0) return;
    for (size_t q = 0; q < A.quads; ++q) {
        float* st = A.stencil.data() + q * A.grid_size * 9;
        for (int32_t r = 0; r < A.side; ++r) {
            for (int32_t c = 0; c < A.side; ++c) {
                float* a = st + (r * A.side + c) * 9;
                if (c + 1 < A.side) {
                    float* b = a + 9;
                    a[stencil_entry(0, 0)] += weight, b[stencil_entry(0, 0)] += weight;
                    a[stencil_entry(0, 1)] -= weight, b[stencil_entry(0, -1)] -= weight;
                }
                if (r + 1 < A.side) {
                    float* b = a + A.side * 9;
                    a[stencil_entry(0, 0)] += weight, b[stencil_entry(0, 0)] += weight;
                    a[stencil_entry(1, 0)] -= weight, b[stencil_entry(-1, 0)] -= weight;
                }
            }
        }
    }
}

// y_c = A x_c for the channels c in `active`.
void multiply(const NormalMatrix& A, const Planes& x, Planes& y, const std::vector<int>& active) {
    const int32_t P = A.side + 2, padded = P * P;  // a zero border, so that no read needs a test
    std::vector<float> local(padded * active.size(), 0.0f);
    for (int c : active) {
        for (size_t k = 0; k < x[c].size(); ++k) y[c][k] = static_cast<float>(A.alpha) * x[c][k];
    }
    for (size_t q = 0; q < A.quads; ++q) {
        const int32_t* ids = A.grid + q * A.grid_size;
        for (size_t n = 0; n < active.size(); ++n) {
            const float* xc = x[active[n]].data();
            float* g = local.data() + n * padded;
            for (int32_t r = 0; r < A.side; ++r) {
                for (int32_t c = 0; c < A.side; ++c) {
                    g[(r + 1) * P + c + 1] = xc[ids[r * A.side + c]];
                }
            }
        }
        const float* st = A.stencil.data() + q * A.grid_size * 9;
        for (int32_t r = 0; r < A.side; ++r) {
            for (int32_t c = 0; c < A.side; ++c, st += 9) {
                const int32_t centre = (r + 1) * P + c + 1, id = ids[r * A.side + c];
                for (size_t n = 0; n < active.size(); ++n) {
                    const float* g = local.data() + n * padded + centre;
                    const float v = st[0] * g[-P - 1] + st[1] * g[-P] + st[2] * g[-P + 1] +
                                    st[3] * g[-1] + st[4] * g[0] + st[5] * g[1] + st[6] * g[P - 1] +
                                    st[7] * g[P] + st[8] * g[P + 1];
                    y[active[n]][id] += v;
                }
            }
        }
    }
}

double dot(const std::vector<float>& a, const std::vector<float>& b) {
    double sum = 0;
    for (size_t k = 0; k < a.size(); ++k) sum += static_cast<double>(a[k]) * b[k];
    return sum;
}

void check_options(const ProjectOptions& o) {
    if (!(o.anchor_weight > 0 && o.anchor_weight <= 1e6)) {
        throw Error(str("projection: anchor weight ", o.anchor_weight, " is not in (0, 10^6]"));
    }
    if (!(o.smoothness >= 0 && o.smoothness <= 1e6)) {
        throw Error(str("projection: smoothness ", o.smoothness, " is not in [0, 10^6]"));
    }
    if (o.max_iterations < 0 || o.max_iterations > 1000) {
        throw Error(str("projection: ", o.max_iterations, " iterations is not in 0..1000"));
    }
    if (!(o.tolerance >= 0 && o.tolerance < 1)) {
        throw Error(str("projection: tolerance ", o.tolerance, " is not in [0, 1)"));
    }
}

}  // namespace

Projection project_image(const Image& image, const Hierarchy& h,
                         std::span<const Vec2> mesh_vertices, const ProjectOptions& o) {
    check_options(o);
    const int level = o.level < 0 ? h.finest() : o.level;
    if (level < 1 || level > h.finest()) {
        throw Error(str("projection: level ", level, " is outside 1..", h.finest()));
    }
    const int channels = image.channels();
    const size_t samples = static_cast<size_t>(h.levels[level].n_vertices);
    Projection result;
    if (o.anchor.empty()) {
        result.planes = sample_image(image, h, mesh_vertices, {.level = level});
    } else {
        if (o.anchor.size() != static_cast<size_t>(channels)) {
            throw Error(
                str("projection: ", o.anchor.size(), " anchor planes for ", channels, " channels"));
        }
        for (const auto& plane : o.anchor) {
            if (plane.size() != samples) {
                throw Error(str("projection: an anchor plane has ", plane.size(), " values, level ",
                                level, " has ", samples, " samples"));
            }
            result.planes.emplace_back(plane.begin(), plane.end());
        }
    }
    for (auto& plane : result.planes) {
        for (float& v : plane) v = std::isfinite(v) ? v : 0.0f;
    }
    Planes anchor = result.planes;
    if (o.max_iterations == 0 || samples == 0) return result;

    const RenderPlan plan = plan_render(h, mesh_vertices, image.width, image.height, image.width,
                                        image.height, {.level = level});
    NormalMatrix A;
    A.side = plan.cells + 1;
    A.grid_size = A.side * A.side;
    A.quads = plan.quad_runs.size() - 1;
    A.grid = plan.grid.data();
    A.stencil.assign(A.quads * A.grid_size * 9, 0.0f);
    const double unit = static_cast<double>(image.width) * image.height / samples;
    A.alpha = o.anchor_weight * unit;
    Planes b(channels, std::vector<float>(samples, 0.0f));
    add_data_term(plan, image, A, b);
    add_smoothness(A, static_cast<float>(o.smoothness * unit));
    A.diagonal.assign(samples, A.alpha);
    for (size_t q = 0; q < A.quads; ++q) {
        for (int32_t k = 0; k < A.grid_size; ++k) {
            A.diagonal[A.grid[q * A.grid_size + k]] +=
                A.stencil[(q * A.grid_size + k) * 9 + stencil_entry(0, 0)];
        }
    }
    for (int c = 0; c < channels; ++c) {
        for (size_t k = 0; k < samples; ++k) b[c][k] += static_cast<float>(A.alpha) * anchor[c][k];
    }

    // Preconditioned conjugate gradients, all channels through one pass over the stencils.
    Planes& x = result.planes;
    Planes r(channels, std::vector<float>(samples)), z = r, p = r, Ap = r;
    std::vector<int> all(channels);
    for (int c = 0; c < channels; ++c) all[c] = c;
    multiply(A, x, Ap, all);
    std::vector<double> rz(channels), norm_b(channels);
    std::vector<int> active;
    for (int c = 0; c < channels; ++c) {
        for (size_t k = 0; k < samples; ++k) {
            r[c][k] = b[c][k] - Ap[c][k];
            z[c][k] = static_cast<float>(r[c][k] / A.diagonal[k]);
        }
        p[c] = z[c];
        rz[c] = dot(r[c], z[c]);
        norm_b[c] = std::sqrt(dot(b[c], b[c]));
        const double relative = norm_b[c] > 0 ? std::sqrt(dot(r[c], r[c])) / norm_b[c] : 0.0;
        result.residual = std::max(result.residual, relative);
        if (relative > o.tolerance) active.push_back(c);
    }
    while (!active.empty() && result.iterations < o.max_iterations) {
        ++result.iterations;
        multiply(A, p, Ap, active);
        std::vector<int> still;
        result.residual = 0;
        for (int c : active) {
            const double pAp = dot(p[c], Ap[c]);
            if (!(pAp > 0)) continue;  // converged to rounding
            const float step = static_cast<float>(rz[c] / pAp);
            for (size_t k = 0; k < samples; ++k) {
                x[c][k] += step * p[c][k];
                r[c][k] -= step * Ap[c][k];
                z[c][k] = static_cast<float>(r[c][k] / A.diagonal[k]);
            }
            const double rz_next = dot(r[c], z[c]);
            const float beta = static_cast<float>(rz_next / rz[c]);
            rz[c] = rz_next;
            for (size_t k = 0; k < samples; ++k) p[c][k] = z[c][k] + beta * p[c][k];
            const double relative = std::sqrt(dot(r[c], r[c])) / norm_b[c];
            result.residual = std::max(result.residual, relative);
            if (relative > o.tolerance) still.push_back(c);
        }
        active = std::move(still);
    }
    return result;
}

Sampling sampling_from_name(std::string_view name) {
    if (name == "point") return Sampling::point;
    if (name == "fit") return Sampling::fit;
    throw Error(str("sampling '", name, "' is not point or fit"));
}

const char* sampling_name(Sampling sampling) {
    return sampling == Sampling::point ? "point" : "fit";
}

std::vector<std::vector<float>> place_image(const Image& image, const Hierarchy& hierarchy,
                                            std::span<const Vec2> mesh_vertices, Sampling sampling,
                                            int level, const ProjectOptions& options) {
    if (sampling == Sampling::point) {
        return sample_image(image, hierarchy, mesh_vertices, {.level = level});
    }
    ProjectOptions o = options;
    o.level = level;
    return project_image(image, hierarchy, mesh_vertices, o).planes;
}

}  // namespace tesswave
