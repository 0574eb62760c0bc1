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
    std::vector<float> stencil;     // per quad, 9 planes of grid_size values (entry-major)
    std::vector<double> diagonal;

    float* entry(size_t q, int e) { return stencil.data() + (q * 9 + e) * grid_size; }
    const float* entry(size_t q, int e) const { return stencil.data() + (q * 9 + e) * grid_size; }
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
                    const int32_t node = cell + offset[a];
                    for (int b = 0; b < 4; ++b) {
                        A.entry(q, stencil_entry(dr[b] - dr[a], dc[b] - dc[a]))[node] +=
                            w[a] * w[b];
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
        float* centre = A.entry(q, stencil_entry(0, 0));
        float* right = A.entry(q, stencil_entry(0, 1));
        float* left = A.entry(q, stencil_entry(0, -1));
        float* down = A.entry(q, stencil_entry(1, 0));
        float* up = A.entry(q, stencil_entry(-1, 0));
        for (int32_t r = 0; r < A.side; ++r) {
            for (int32_t c = 0; c < A.side; ++c) {
                const int32_t a = r * A.side + c;
                if (c + 1 < A.side) {
                    centre[a] += weight, centre[a + 1] += weight;
                    right[a] -= weight, left[a + 1] -= weight;
                }
                if (r + 1 < A.side) {
                    centre[a] += weight, centre[a + A.side] += weight;
                    down[a] -= weight, up[a + A.side] -= weight;
                }
            }
        }
    }
}

// y_c = A x_c for the channels c in `active`: per quad, its grid of x gathered into a padded
// buffer, the stencil applied row by row (entry-major, so the rows vectorize), the result added
// back at the grid's sample ids.
void multiply(const NormalMatrix& A, const Planes& x, Planes& y, const std::vector<int>& active) {
    const int32_t side = A.side, P = side + 2,
                  padded = P * P;  // a zero border: no read needs a test
    std::vector<float> local(padded, 0.0f), out(side);
    for (int c : active) {
        for (size_t k = 0; k < x[c].size(); ++k) y[c][k] = static_cast<float>(A.alpha) * x[c][k];
    }
    const int32_t offset[9] = {-P - 1, -P, -P + 1, -1, 0, 1, P - 1, P, P + 1};
    for (size_t q = 0; q < A.quads; ++q) {
        const int32_t* ids = A.grid + q * A.grid_size;
        for (int ch : active) {
            const float* __restrict xc = x[ch].data();
            float* __restrict yc = y[ch].data();
            for (int32_t r = 0; r < side; ++r) {
                float* g = local.data() + (r + 1) * P + 1;
                const int32_t* row_ids = ids + r * side;
                for (int32_t c = 0; c < side; ++c) g[c] = xc[row_ids[c]];
            }
            for (int32_t r = 0; r < side; ++r) {
                const float* g = local.data() + (r + 1) * P + 1;
                float* __restrict o = out.data();
                for (int32_t c = 0; c < side; ++c) o[c] = 0.0f;
                for (int e = 0; e < 9; ++e) {
                    const float* __restrict st = A.entry(q, e) + r * side;
                    const float* __restrict ge = g + offset[e];
                    for (int32_t c = 0; c < side; ++c) o[c] += st[c] * ge[c];
                }
                const int32_t* row_ids = ids + r * side;
                for (int32_t c = 0; c < side; ++c) yc[row_ids[c]] += o[c];
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
    A.stencil.assign(A.quads * 9 * A.grid_size, 0.0f);
    const double unit = static_cast<double>(image.width) * image.height / samples;
    A.alpha = o.anchor_weight * unit;
    Planes b(channels, std::vector<float>(samples, 0.0f));
    add_data_term(plan, image, A, b);
    add_smoothness(A, static_cast<float>(o.smoothness * unit));
    A.diagonal.assign(samples, A.alpha);
    for (size_t q = 0; q < A.quads; ++q) {
        for (int32_t k = 0; k < A.grid_size; ++k) {
            A.diagonal[A.grid[q * A.grid_size + k]] += A.entry(q, stencil_entry(0, 0))[k];
        }
    }
    for (int c = 0; c < channels; ++c) {
        for (size_t k = 0; k < samples; ++k) b[c][k] += static_cast<float>(A.alpha) * anchor[c][k];
    }

    // Preconditioned conjugate gradients, all channels through one pass over the stencils. The
    // preconditioned residual z = r / diagonal is never stored: r.z and p = z + beta p read r.
    std::vector<float> inverse(samples);
    for (size_t k = 0; k < samples; ++k) inverse[k] = static_cast<float>(1.0 / A.diagonal[k]);
    Planes& x = result.planes;
    Planes r(channels, std::vector<float>(samples)), p = r, Ap = r;
    std::vector<int> all(channels);
    for (int c = 0; c < channels; ++c) all[c] = c;
    multiply(A, x, Ap, all);
    std::vector<double> rz(channels), norm_b(channels);
    std::vector<int> active;
    for (int c = 0; c < channels; ++c) {
        double rr = 0;
        for (size_t k = 0; k < samples; ++k) {
            r[c][k] = b[c][k] - Ap[c][k];
            p[c][k] = r[c][k] * inverse[k];
            rz[c] += double{r[c][k]} * p[c][k];
            rr += double{r[c][k]} * r[c][k];
        }
        norm_b[c] = std::sqrt(dot(b[c], b[c]));
        const double relative = norm_b[c] > 0 ? std::sqrt(rr) / norm_b[c] : 0.0;
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
            float* __restrict xc = x[c].data();
            float* __restrict rc = r[c].data();
            float* __restrict pc = p[c].data();
            const float* __restrict apc = Ap[c].data();
            double rz_next = 0, rr = 0;
            for (size_t k = 0; k < samples; ++k) {
                xc[k] += step * pc[k];
                rc[k] -= step * apc[k];
                rz_next += double{rc[k]} * (rc[k] * inverse[k]);
                rr += double{rc[k]} * rc[k];
            }
            const float beta = static_cast<float>(rz_next / rz[c]);
            rz[c] = rz_next;
            for (size_t k = 0; k < samples; ++k) pc[k] = rc[k] * inverse[k] + beta * pc[k];
            const double relative = std::sqrt(rr) / norm_b[c];
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
