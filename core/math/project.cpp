#include "core/math/project.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <utility>

#include "core/math/error.h"
#include "core/math/parallel.h"
#include "core/math/project_grids.h"
#include "core/math/render.h"
#include "core/math/sampling.h"
#include "core/math/strings.h"

namespace tesswave {
namespace {

using detail::add_stashed;
using detail::dot;
using detail::find_shared;
using detail::from_local;
using detail::LocalGrids;
using detail::make_local;
using detail::multiply;
using detail::NormalMatrix;
using detail::Planes;
using detail::SharedNodes;
using detail::stencil_entry;
using detail::to_local;

// Zeroes the stencils and adds the data term (and the right-hand side R^T M I) of every pixel the
// plan renders, the quads shared among the cores. A quad's stencils are its own; its right-hand
// side is summed per quad, written at once where the quad owns the node, and otherwise kept in
// `stash` and added afterwards in quad order (the same sums whatever the thread count).
void add_data_term(const RenderPlan& plan, const Image& image, const SharedNodes& shared,
                   NormalMatrix& A, Planes& rhs) {
    const int channels = image.channels();
    constexpr float kUnit = 1.0f / 65536.0f;
    const int32_t side = A.side;
    // The pixels of quad q are the plan's entries from first_pixel[q] on.
    std::vector<size_t> first_pixel(A.quads + 1, 0);
    for (size_t q = 0; q < A.quads; ++q) {
        size_t count = 0;
        for (int32_t run = plan.quad_runs[q]; run < plan.quad_runs[q + 1]; ++run)
            count += static_cast<size_t>(plan.run_length[run]);
        first_pixel[q + 1] = first_pixel[q] + count;
    }
    A.pixels.resize(A.quads);
    for (size_t q = 0; q < A.quads; ++q)
        A.pixels[q] = static_cast<int64_t>(first_pixel[q + 1] - first_pixel[q]);
    const size_t stashed = shared.k.size();
    std::vector<float> stash(static_cast<size_t>(channels) * stashed);
    parallel_for(static_cast<int64_t>(A.quads), [&](int64_t begin, int64_t end) {
        std::vector<float> local(static_cast<size_t>(channels) * A.grid_size);
        for (auto q = static_cast<size_t>(begin); q < static_cast<size_t>(end); ++q) {
            std::fill_n(A.entry(q, 0), 9 * static_cast<size_t>(A.grid_size), 0.0f);
            float* e[9];
            for (int k = 0; k < 9; ++k) e[k] = A.entry(q, k);
            std::fill(local.begin(), local.end(), 0.0f);
            size_t i = first_pixel[q];
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
                    // The 16 products of the four weights, each to its own entry and node (so
                    // their order does not matter): node a gets w_a w_b at entry (b - a).
                    const int32_t n0 = cell, n1 = cell + 1, n2 = cell + side, n3 = n2 + 1;
                    e[4][n0] += w[0] * w[0], e[5][n0] += w[0] * w[1];
                    e[7][n0] += w[0] * w[2], e[8][n0] += w[0] * w[3];
                    e[3][n1] += w[1] * w[0], e[4][n1] += w[1] * w[1];
                    e[6][n1] += w[1] * w[2], e[7][n1] += w[1] * w[3];
                    e[1][n2] += w[2] * w[0], e[2][n2] += w[2] * w[1];
                    e[4][n2] += w[2] * w[2], e[5][n2] += w[2] * w[3];
                    e[0][n3] += w[3] * w[0], e[1][n3] += w[3] * w[1];
                    e[3][n3] += w[3] * w[2], e[4][n3] += w[3] * w[3];
                    for (int c = 0; c < channels; ++c) {
                        float* l = local.data() + c * A.grid_size;
                        const float v = image.planes[c][px];
                        l[n0] += w[0] * v, l[n1] += w[1] * v, l[n2] += w[2] * v, l[n3] += w[3] * v;
                    }
                }
            }
            const int32_t* ids = A.grid + q * A.grid_size;
            const uint8_t* is_shared = shared.shared.data() + q * A.grid_size;
            for (int c = 0; c < channels; ++c) {
                int32_t next = shared.offsets[q];
                const float* l = local.data() + c * A.grid_size;
                for (int32_t k = 0; k < A.grid_size; ++k) {
                    if (is_shared[k]) {
                        stash[c * stashed + next++] = l[k];
                    } else {
                        rhs[c][ids[k]] = l[k];
                    }
                }
            }
        }
    });
    for (int c = 0; c < channels; ++c)
        add_stashed(A, shared, stash.data() + c * stashed, rhs[c].data());
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

// The projection's set-up, shared by the solves of several smoothness values: the anchor, the
// render plan, the stencils with the data term, and the right-hand side.
class Solver {
  public:
    Solver(const Image& image, const Hierarchy& h, std::span<const Vec2> mesh_vertices,
           const ProjectOptions& o)
        : o_(o) {
        check_options(o);
        const int level = o.level < 0 ? h.finest() : o.level;
        if (level < 1 || level > h.finest()) {
            throw Error(str("projection: level ", level, " is outside 1..", h.finest()));
        }
        channels_ = image.channels();
        samples_ = static_cast<size_t>(h.levels[level].n_vertices);
        anchor_ = o.anchor.empty() ? sample_image(image, h, mesh_vertices, {.level = level})
                                   : anchor_of(o.anchor);
        for (auto& plane : anchor_) {
            for (float& v : plane) v = std::isfinite(v) ? v : 0.0f;
        }
        if (o.max_iterations == 0 || samples_ == 0) return;

        if (o.plan) {
            if (o.plan->width != image.width || o.plan->height != image.height ||
                o.plan->level != level || o.plan->samples != static_cast<int32_t>(samples_)) {
                throw Error(str("projection: the given render plan is ", o.plan->width, "x",
                                o.plan->height, " at level ", o.plan->level, "; the image is ",
                                image.width, "x", image.height, " at level ", level));
            }
            plan_ = o.plan;
        } else {
            own_plan_ = plan_render(h, mesh_vertices, image.width, image.height, image.width,
                                    image.height, {.level = level});
            plan_ = &own_plan_;
        }
        const RenderPlan& plan = *plan_;
        A_.side = plan.cells + 1;
        A_.grid_size = A_.side * A_.side;
        A_.quads = plan.quad_runs.size() - 1;
        A_.grid = plan.grid.data();
        A_.stencil.reset(new float[A_.quads * 9 * A_.grid_size]);  // zeroed by add_data_term
        shared_ = find_shared(A_, samples_);
        unit_ = static_cast<double>(image.width) * image.height / samples_;
        A_.alpha = o.anchor_weight * unit_;
        Planes b(channels_, std::vector<float>(samples_, 0.0f));
        add_data_term(plan, image, shared_, A_, b);
        for (int c = 0; c < channels_; ++c) {
            for (size_t k = 0; k < samples_; ++k)
                b[c][k] += static_cast<float>(A_.alpha) * anchor_[c][k];
        }
        local_ = make_local(A_, shared_, samples_);
        b_.resize(channels_);
        for (int c = 0; c < channels_; ++c) to_local(A_, local_, b[c], b_[c]);
    }

    // The starting samples: the anchor.
    Projection start() const { return {.planes = anchor_}; }

    // Solves for `smoothness` from the samples in `x` (its planes), which it overwrites.
    void solve(double smoothness, Projection& x);

  private:
    Planes anchor_of(std::span<const std::span<const float>> given) const {
        if (given.size() != static_cast<size_t>(channels_)) {
            throw Error(
                str("projection: ", given.size(), " anchor planes for ", channels_, " channels"));
        }
        Planes out;
        for (const auto& plane : given) {
            if (plane.size() != samples_) {
                throw Error(str("projection: an anchor plane has ", plane.size(),
                                " values, the level has ", samples_, " samples"));
            }
            out.emplace_back(plane.begin(), plane.end());
        }
        return out;
    }

    ProjectOptions o_;
    int channels_ = 0;
    size_t samples_ = 0;
    Planes anchor_;
    Planes b_;  // the right-hand side, on the local grids
    RenderPlan own_plan_;
    const RenderPlan* plan_ = nullptr;  // own_plan_ or the caller's
    NormalMatrix A_;
    SharedNodes shared_;
    LocalGrids local_;
    double unit_ = 0;
    double smoothness_ = 0;  // what the stencils hold
};

void Solver::solve(double smoothness, Projection& result) {
    result.iterations = 0;
    result.residual = 0;
    if (!(smoothness >= 0 && smoothness <= 1e6)) {
        throw Error(str("projection: smoothness ", smoothness, " is not in [0, 10^6]"));
    }
    if (o_.max_iterations == 0 || samples_ == 0) return;
    // The stencils move from the smoothness they hold to this one.
    add_smoothness(A_, static_cast<float>((smoothness - smoothness_) * unit_));
    smoothness_ = smoothness;
    A_.diagonal.assign(samples_, A_.alpha);
    for (size_t q = 0; q < A_.quads; ++q) {
        for (int32_t k = 0; k < A_.grid_size; ++k) {
            A_.diagonal[A_.grid[q * A_.grid_size + k]] += A_.entry(q, stencil_entry(0, 0))[k];
        }
    }
    const int channels = channels_;
    const LocalGrids& g = local_;
    const size_t size = g.size;
    const Planes& b = b_;
    const std::vector<float>& owner = g.owner;

    // Preconditioned conjugate gradients on the local grids, all channels through one pass over
    // the stencils. With Jacobi, the preconditioned residual z = r / diagonal is never stored:
    // r.z and p = z + beta p read r; the line preconditioner writes z where A p was (no longer
    // needed once x and r have stepped). The products p.Ap and r.z come with the passes that make
    // Ap and z.
    detail::LinePreconditioner lp;
    if (o_.preconditioner == Preconditioner::lines) lp = detail::make_line_preconditioner(A_, g);
    const bool lines = lp.any;   // where every quad keeps Jacobi, the Jacobi path is cheaper
    std::vector<float> inverse;  // Jacobi's: 0 in the margins, which stay 0
    if (!lines) {
        inverse.assign(size, 0.0f);
        for (size_t q = 0; q < A_.quads; ++q) {
            for (int32_t k = 0; k < A_.grid_size; ++k) {
                inverse[g.index(q, k)] =
                    static_cast<float>(1.0 / A_.diagonal[A_.grid[q * A_.grid_size + k]]);
            }
        }
    }
    Planes x(channels), r(channels, std::vector<float>(size, 0.0f)), p = r, Ap = r;
    for (int c = 0; c < channels; ++c) to_local(A_, g, result.planes[c], x[c]);
    std::vector<int> all(channels);
    for (int c = 0; c < channels; ++c) all[c] = c;
    std::vector<float> products;
    multiply(A_, shared_, g, x, Ap, all, products);
    for (int c = 0; c < channels; ++c) {
        for (size_t k = 0; k < size; ++k) r[c][k] = b[c][k] - Ap[c][k];
        if (!lines) {
            for (size_t k = 0; k < size; ++k) p[c][k] = r[c][k] * inverse[k];
        }
    }
    std::vector<double> rz(channels), norm_b(channels), pAp, rz_lines;
    if (lines) {
        detail::precondition(A_, shared_, g, lp, r, p, all, products, &rz_lines);
        for (size_t a = 0; a < all.size(); ++a) rz[all[a]] = rz_lines[a];
    }
    std::vector<int> active;
    for (int c = 0; c < channels; ++c) {
        if (!lines) rz[c] = dot(r[c], p[c], owner);
        const double rr = dot(r[c], r[c], owner);
        norm_b[c] = std::sqrt(dot(b[c], b[c], owner));
        const double relative = norm_b[c] > 0 ? std::sqrt(rr) / norm_b[c] : 0.0;
        result.residual = std::max(result.residual, relative);
        if (relative > o_.tolerance) active.push_back(c);
    }
    const detail::VectorKernels& kernels = detail::vector_kernels();
    while (!active.empty() && result.iterations < o_.max_iterations) {
        ++result.iterations;
        multiply(A_, shared_, g, p, Ap, active, products, &pAp);
        // Each channel's step on its own (the channels shared among the cores).
        const size_t n = active.size();
        std::vector<double> relative(n, -1.0);
        parallel_for(static_cast<int64_t>(n), [&](int64_t begin, int64_t end) {
            for (auto a = static_cast<size_t>(begin); a < static_cast<size_t>(end); ++a) {
                const int c = active[a];
                if (!(pAp[a] > 0)) continue;  // converged to rounding
                const float step = static_cast<float>(rz[c] / pAp[a]);
                float* __restrict rc = r[c].data();
                float* __restrict pc = p[c].data();
                if (lines) {
                    const double rr = kernels.step_residual(step, x[c].data(), rc, pc, Ap[c].data(),
                                                            owner.data(), size);
                    relative[a] = std::sqrt(rr) / norm_b[c];
                    continue;  // p follows once z is known
                }
                const auto [rz_next, rr] = kernels.step_channel(
                    step, x[c].data(), rc, pc, Ap[c].data(), inverse.data(), owner.data(), size);
                const float beta = static_cast<float>(rz_next / rz[c]);
                rz[c] = rz_next;
                kernels.next_direction(beta, rc, inverse.data(), pc, size);
                relative[a] = std::sqrt(rr) / norm_b[c];
            }
        });
        std::vector<int> still;
        result.residual = 0;
        for (size_t a = 0; a < n; ++a) {
            if (relative[a] < 0) continue;
            result.residual = std::max(result.residual, relative[a]);
            if (relative[a] > o_.tolerance) still.push_back(active[a]);
        }
        active = std::move(still);
        if (lines && !active.empty() && result.iterations < o_.max_iterations) {
            Planes& z = Ap;
            detail::precondition(A_, shared_, g, lp, r, z, active, products, &rz_lines);
            parallel_for(static_cast<int64_t>(active.size()), [&](int64_t begin, int64_t end) {
                for (auto a = static_cast<size_t>(begin); a < static_cast<size_t>(end); ++a) {
                    const int c = active[a];
                    const float beta = static_cast<float>(rz_lines[a] / rz[c]);
                    rz[c] = rz_lines[a];
                    kernels.next_direction_from(beta, z[c].data(), p[c].data(), size);
                }
            });
        }
    }
    for (int c = 0; c < channels; ++c) from_local(A_, g, x[c], result.planes[c]);
}

}  // namespace

Projection project_image(const Image& image, const Hierarchy& h,
                         std::span<const Vec2> mesh_vertices, const ProjectOptions& o) {
    Solver solver(image, h, mesh_vertices, o);
    Projection result = solver.start();
    solver.solve(o.smoothness, result);
    return result;
}

void project_image_each(const Image& image, const Hierarchy& h, std::span<const Vec2> mesh_vertices,
                        std::span<const double> smoothness, const ProjectOptions& o,
                        const std::function<void(size_t, const Projection&)>& take) {
    Solver solver(image, h, mesh_vertices, o);
    Projection result = solver.start();
    for (size_t k = 0; k < smoothness.size(); ++k) {
        solver.solve(smoothness[k], result);
        take(k, result);
    }
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
