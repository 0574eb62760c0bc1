#include "core/math/project.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <utility>

#include "core/math/error.h"
#include "core/math/parallel.h"
#include "core/math/render.h"
#include "core/math/sampling.h"
#include "core/math/strings.h"

// The hot loops below are compiled twice on x86-64, for AVX2 and for the baseline, and picked at
// load time (elsewhere they are compiled once).
#if defined(__x86_64__)
#define TESSWAVE_AVX2_CLONES [[gnu::target_clones("avx2", "default")]]
#else
#define TESSWAVE_AVX2_CLONES
#endif

namespace tesswave {
namespace {

using Planes = std::vector<std::vector<float>>;

// R^T M R + beta u L as a 3x3 stencil for every node of every quad's (m+1)^2 grid, entry
// (dr + 1) * 3 + (dc + 1) for the neighbour dr rows and dc columns away; a node shared by several
// quads sums their stencils. `diagonal` holds the whole matrix's diagonal, alpha u included.
struct NormalMatrix {
    int32_t side = 0, grid_size = 0;
    size_t quads = 0;
    const int32_t* grid = nullptr;     // the plan's sample ids, grid_size a quad
    std::unique_ptr<float[]> stencil;  // per quad, 9 planes of grid_size values (entry-major)
    std::vector<double> diagonal;

    float* entry(size_t q, int e) { return stencil.get() + (q * 9 + e) * grid_size; }
    const float* entry(size_t q, int e) const { return stencil.get() + (q * 9 + e) * grid_size; }
    double alpha = 0;  // alpha u
};

constexpr int stencil_entry(int dr, int dc) { return (dr + 1) * 3 + (dc + 1); }

// Which grid nodes of the quads are shared by several quads (the rest, a quad's own, are written
// by that quad alone): per quad, the positions of its shared nodes.
struct SharedNodes {
    std::vector<uint8_t> shared;      // per quad and grid position
    std::vector<int32_t> offsets, k;  // per quad, [offsets[q], offsets[q + 1]) of k
};

SharedNodes find_shared(const NormalMatrix& A, size_t samples) {
    std::vector<uint8_t> count(samples, 0);
    const size_t nodes = A.quads * A.grid_size;
    for (size_t i = 0; i < nodes; ++i)
        count[A.grid[i]] = static_cast<uint8_t>(std::min(count[A.grid[i]] + 1, 2));
    SharedNodes s;
    s.shared.resize(nodes);
    s.offsets.push_back(0);
    for (size_t q = 0; q < A.quads; ++q) {
        for (int32_t k = 0; k < A.grid_size; ++k) {
            const size_t i = q * A.grid_size + k;
            s.shared[i] = count[A.grid[i]] > 1;
            if (s.shared[i]) s.k.push_back(k);
        }
        s.offsets.push_back(static_cast<int32_t>(s.k.size()));
    }
    return s;
}

// Adds the values stashed for the shared nodes (one per entry of s.k) to `plane` at their sample
// ids, in quad order: the same sums whatever the thread count.
void add_stashed(const NormalMatrix& A, const SharedNodes& s, const float* stash, float* plane) {
    for (size_t q = 0; q < A.quads; ++q) {
        const int32_t* ids = A.grid + q * A.grid_size;
        for (int32_t i = s.offsets[q]; i < s.offsets[q + 1]; ++i) plane[ids[s.k[i]]] += stash[i];
    }
}

// Zeroes the stencils and adds the data term (and the right-hand side R^T M I) of every pixel the
// plan renders, the quads shared among the cores. A quad's stencils are its own; its right-hand
// side is summed per quad, written at once where the quad owns the node, and otherwise kept in
// `stash` and added afterwards in quad order (the same sums whatever the thread count).
void add_data_term(const RenderPlan& plan, const Image& image, const SharedNodes& shared,
                   NormalMatrix& A, Planes& rhs) {
    const int channels = image.channels();
    constexpr float kUnit = 1.0f / 65536.0f;
    const int dr[4] = {0, 0, 1, 1}, dc[4] = {0, 1, 0, 1};
    const int32_t offset[4] = {0, 1, A.side, A.side + 1};
    // The pixels of quad q are the plan's entries from first_pixel[q] on.
    std::vector<size_t> first_pixel(A.quads + 1, 0);
    for (size_t q = 0; q < A.quads; ++q) {
        size_t count = 0;
        for (int32_t run = plan.quad_runs[q]; run < plan.quad_runs[q + 1]; ++run)
            count += static_cast<size_t>(plan.run_length[run]);
        first_pixel[q + 1] = first_pixel[q] + count;
    }
    const size_t stashed = shared.k.size();
    std::vector<float> stash(static_cast<size_t>(channels) * stashed);
    parallel_for(static_cast<int64_t>(A.quads), [&](int64_t begin, int64_t end) {
        std::vector<float> local(static_cast<size_t>(channels) * A.grid_size);
        for (auto q = static_cast<size_t>(begin); q < static_cast<size_t>(end); ++q) {
            std::fill_n(A.entry(q, 0), 9 * static_cast<size_t>(A.grid_size), 0.0f);
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
                    for (int a = 0; a < 4; ++a) {
                        const int32_t node = cell + offset[a];
                        for (int b = 0; b < 4; ++b) {
                            A.entry(q, stencil_entry(dr[b] - dr[a], dc[b] - dc[a]))[node] +=
                                w[a] * w[b];
                        }
                        for (int c = 0; c < channels; ++c)
                            local[c * A.grid_size + node] += w[a] * image.planes[c][px];
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

// o[c] = sum over the nine entries e of st[e][c] g[c + offset[e]], c < n, each sum made in entry
// order. Compiled twice, for AVX2 and for the baseline x86-64, and picked at load time: the
// vectorized rows run 8 lanes wide where the machine has them. Both versions do the same float
// multiplications and additions in the same order (no fused multiply-add), so the results are the
// same to the bit on any machine.
TESSWAVE_AVX2_CLONES void stencil_row(const float* const* st, const float* g, const int32_t* offset,
                                      int32_t n, float* __restrict o) {
    const float* __restrict s0 = st[0];
    const float* __restrict s1 = st[1];
    const float* __restrict s2 = st[2];
    const float* __restrict s3 = st[3];
    const float* __restrict s4 = st[4];
    const float* __restrict s5 = st[5];
    const float* __restrict s6 = st[6];
    const float* __restrict s7 = st[7];
    const float* __restrict s8 = st[8];
    const float* __restrict g0 = g + offset[0];
    const float* __restrict g1 = g + offset[1];
    const float* __restrict g2 = g + offset[2];
    const float* __restrict g3 = g + offset[3];
    const float* __restrict g4 = g + offset[4];
    const float* __restrict g5 = g + offset[5];
    const float* __restrict g6 = g + offset[6];
    const float* __restrict g7 = g + offset[7];
    const float* __restrict g8 = g + offset[8];
    for (int32_t c = 0; c < n; ++c) {
        float sum = 0.0f;
        sum += s0[c] * g0[c];
        sum += s1[c] * g1[c];
        sum += s2[c] * g2[c];
        sum += s3[c] * g3[c];
        sum += s4[c] * g4[c];
        sum += s5[c] * g5[c];
        sum += s6[c] * g6[c];
        sum += s7[c] * g7[c];
        sum += s8[c] * g8[c];
        o[c] = sum;
    }
}

// The solver's vectors, per channel, live in the quads' grids: quad q's side^2 values, row by row
// as in the plan, one quad after the other, so that the stencil reads a node's neighbours at fixed
// offsets and no value is fetched through its sample id. A stencil entry that points out of its
// quad's grid is zero (R^T R and the smoothness couple nodes of one quad only), so what such a read
// finds (the next row, the next quad, or the zero margin at either end) counts for nothing. A
// sample on the border of several quads has a copy in each, and every copy holds the same value
// (each is updated by the same arithmetic on the same values). Dot products count a sample once,
// at its first copy. The vectors are (side / (side - 1))^2 times the samples: 1.06 at 32 cells a
// side, 2.25 at 2, 4 at 1.
struct LocalGrids {
    int32_t side = 0, grid_size = 0;
    size_t margin = 0, size = 0;  // margin: zeros before the first quad and after the last
    std::vector<float> owner;     // 1 at each sample's first copy, else 0 (the margins too)
    // The shared samples, each with [offsets[i], offsets[i + 1]) of `copy` and `stashed`: its
    // copies' local indices, in quad order, and where each copy's product waits (SharedNodes').
    std::vector<int32_t> offsets, copy, stashed;

    size_t index(size_t q, int32_t k) const { return margin + q * grid_size + k; }
};

LocalGrids make_local(const NormalMatrix& A, const SharedNodes& s, size_t samples) {
    LocalGrids g;
    g.side = A.side;
    g.grid_size = A.grid_size;
    g.margin = static_cast<size_t>(A.side) + 1;
    g.size = A.quads * A.grid_size + 2 * g.margin;
    g.owner.assign(g.size, 0.0f);
    std::vector<uint8_t> seen(samples, 0);
    for (size_t q = 0; q < A.quads; ++q) {
        for (int32_t k = 0; k < A.grid_size; ++k) {
            const int32_t id = A.grid[q * A.grid_size + k];
            if (!seen[id]) seen[id] = 1, g.owner[g.index(q, k)] = 1.0f;
        }
    }
    // The shared copies grouped by sample (groups in the order of their first copy), each group in
    // quad order: a stable counting sort of the stash entries.
    std::vector<int32_t> group(samples, -1), count;
    std::vector<int32_t> entry_group(s.k.size());
    for (size_t q = 0; q < A.quads; ++q) {
        for (int32_t i = s.offsets[q]; i < s.offsets[q + 1]; ++i) {
            const int32_t id = A.grid[q * A.grid_size + s.k[i]];
            if (group[id] < 0) {
                group[id] = static_cast<int32_t>(count.size());
                count.push_back(0);
            }
            entry_group[i] = group[id];
            ++count[group[id]];
        }
    }
    g.offsets.assign(count.size() + 1, 0);
    for (size_t i = 0; i < count.size(); ++i) g.offsets[i + 1] = g.offsets[i] + count[i];
    g.copy.resize(s.k.size());
    g.stashed.resize(s.k.size());
    std::vector<int32_t> next(g.offsets.begin(), g.offsets.end() - 1);
    for (size_t q = 0; q < A.quads; ++q) {
        for (int32_t i = s.offsets[q]; i < s.offsets[q + 1]; ++i) {
            const int32_t at = next[entry_group[i]]++;
            g.copy[at] = static_cast<int32_t>(g.index(q, s.k[i]));
            g.stashed[at] = i;
        }
    }
    return g;
}

// The local copies of a plane of samples, and back (from each sample's first copy).
void to_local(const NormalMatrix& A, const LocalGrids& g, const std::vector<float>& plane,
              std::vector<float>& local) {
    local.assign(g.size, 0.0f);
    parallel_for(static_cast<int64_t>(A.quads), [&](int64_t begin, int64_t end) {
        for (auto q = static_cast<size_t>(begin); q < static_cast<size_t>(end); ++q) {
            const int32_t* ids = A.grid + q * A.grid_size;
            for (int32_t k = 0; k < A.grid_size; ++k) local[g.index(q, k)] = plane[ids[k]];
        }
    });
}

void from_local(const NormalMatrix& A, const LocalGrids& g, const std::vector<float>& local,
                std::vector<float>& plane) {
    for (size_t q = 0; q < A.quads; ++q) {
        const int32_t* ids = A.grid + q * A.grid_size;
        for (int32_t k = 0; k < A.grid_size; ++k) {
            const size_t i = g.index(q, k);
            if (g.owner[i] != 0) plane[ids[k]] = local[i];
        }
    }
}

// y_c = A x_c for the channels c in `active`, on the local grids, the quads shared among the cores:
// per quad, the stencil applied row by row (entry-major, so the rows vectorize). An unshared node
// gets y = alpha u x + its product at once; a shared node's product waits in `products`, and its
// copies then get alpha u x plus the products of all its quads, added in quad order, so that every
// sum is made in the same order whatever the thread count.
void multiply(const NormalMatrix& A, const SharedNodes& s, const LocalGrids& g, const Planes& x,
              Planes& y, const std::vector<int>& active, std::vector<float>& products) {
    const int32_t side = g.side, grid_size = g.grid_size;
    const size_t n = active.size(), shared = s.k.size();
    products.resize(n * shared);
    const float alpha = static_cast<float>(A.alpha);
    const int32_t offset[9] = {-side - 1, -side, -side + 1, -1, 0, 1, side - 1, side, side + 1};
    parallel_for(static_cast<int64_t>(A.quads), [&](int64_t begin, int64_t end) {
        for (auto q = static_cast<size_t>(begin); q < static_cast<size_t>(end); ++q) {
            const float* st[9];
            for (int e = 0; e < 9; ++e) st[e] = A.entry(q, e);
            for (size_t a = 0; a < n; ++a) {
                const float* __restrict xq = x[active[a]].data() + g.index(q, 0);
                float* __restrict yq = y[active[a]].data() + g.index(q, 0);
                stencil_row(st, xq, offset, grid_size, yq);  // the whole grid as one row
                float* stash = products.data() + a * shared;
                for (int32_t i = s.offsets[q]; i < s.offsets[q + 1]; ++i) stash[i] = yq[s.k[i]];
                for (int32_t k = 0; k < grid_size; ++k) yq[k] = alpha * xq[k] + yq[k];
            }
        }
    });
    const auto groups = static_cast<int64_t>(g.offsets.size()) - 1;
    parallel_for(
        groups,
        [&](int64_t begin, int64_t end) {
            for (size_t a = 0; a < n; ++a) {
                const float* xc = x[active[a]].data();
                float* yc = y[active[a]].data();
                const float* stash = products.data() + a * shared;
                for (int64_t i = begin; i < end; ++i) {
                    float total = alpha * xc[g.copy[g.offsets[i]]];
                    for (int32_t j = g.offsets[i]; j < g.offsets[i + 1]; ++j)
                        total += stash[g.stashed[j]];
                    for (int32_t j = g.offsets[i]; j < g.offsets[i + 1]; ++j) yc[g.copy[j]] = total;
                }
            }
        },
        1024);
}

// The reductions below keep four partial sums (k mod 4), so that a loop is not bound by the
// latency of one double accumulator; the order, and so the result, is fixed. `owner` counts each
// sample once. Like stencil_row, each is compiled for AVX2 and the baseline, with the same
// arithmetic in the same order (the four sums are the four lanes of a vector).
TESSWAVE_AVX2_CLONES double dot(const float* __restrict a, const float* __restrict b,
                                const float* __restrict owner, size_t n) {
    double sum[4] = {0, 0, 0, 0};
    const size_t whole = n - n % 4;
    for (size_t k = 0; k < whole; k += 4) {
        for (int i = 0; i < 4; ++i)
            sum[i] += static_cast<double>(a[k + i] * owner[k + i]) * b[k + i];
    }
    for (size_t k = whole; k < n; ++k) sum[k % 4] += static_cast<double>(a[k] * owner[k]) * b[k];
    return (sum[0] + sum[1]) + (sum[2] + sum[3]);
}

double dot(const std::vector<float>& a, const std::vector<float>& b,
           const std::vector<float>& owner) {
    return dot(a.data(), b.data(), owner.data(), a.size());
}

// One conjugate-gradient step of a channel, in one pass: x += step p, r -= step Ap; returns r.z
// (z = r / d) and r.r.
TESSWAVE_AVX2_CLONES std::pair<double, double> step_channel(
    float step, float* __restrict x, float* __restrict r, const float* __restrict p,
    const float* __restrict ap, const float* __restrict inverse, const float* __restrict owner,
    size_t n) {
    double rz[4] = {0, 0, 0, 0}, rr[4] = {0, 0, 0, 0};
    const size_t whole = n - n % 4;
    for (size_t k = 0; k < whole; k += 4) {
        for (int i = 0; i < 4; ++i) {
            x[k + i] += step * p[k + i];
            r[k + i] -= step * ap[k + i];
            const double v = r[k + i] * owner[k + i];
            rz[i] += v * (r[k + i] * inverse[k + i]);
            rr[i] += v * r[k + i];
        }
    }
    for (size_t k = whole; k < n; ++k) {
        x[k] += step * p[k];
        r[k] -= step * ap[k];
        const double v = r[k] * owner[k];
        rz[k % 4] += v * (r[k] * inverse[k]);
        rr[k % 4] += v * r[k];
    }
    return {(rz[0] + rz[1]) + (rz[2] + rz[3]), (rr[0] + rr[1]) + (rr[2] + rr[3])};
}

// The next search direction: p = r / d + beta p.
TESSWAVE_AVX2_CLONES void next_direction(float beta, const float* __restrict r,
                                         const float* __restrict inverse, float* __restrict p,
                                         size_t n) {
    for (size_t k = 0; k < n; ++k) p[k] = r[k] * inverse[k] + beta * p[k];
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
    // the stencils. The preconditioned residual z = r / diagonal is never stored: r.z and
    // p = z + beta p read r.
    std::vector<float> inverse(size, 0.0f);  // 0 in the margins, which stay 0
    for (size_t q = 0; q < A_.quads; ++q) {
        for (int32_t k = 0; k < A_.grid_size; ++k) {
            inverse[g.index(q, k)] =
                static_cast<float>(1.0 / A_.diagonal[A_.grid[q * A_.grid_size + k]]);
        }
    }
    Planes x(channels), r(channels, std::vector<float>(size, 0.0f)), p = r, Ap = r;
    for (int c = 0; c < channels; ++c) to_local(A_, g, result.planes[c], x[c]);
    std::vector<int> all(channels);
    for (int c = 0; c < channels; ++c) all[c] = c;
    std::vector<float> products;
    multiply(A_, shared_, g, x, Ap, all, products);
    std::vector<double> rz(channels), norm_b(channels);
    std::vector<int> active;
    for (int c = 0; c < channels; ++c) {
        for (size_t k = 0; k < size; ++k) {
            r[c][k] = b[c][k] - Ap[c][k];
            p[c][k] = r[c][k] * inverse[k];
        }
        rz[c] = dot(r[c], p[c], owner);
        const double rr = dot(r[c], r[c], owner);
        norm_b[c] = std::sqrt(dot(b[c], b[c], owner));
        const double relative = norm_b[c] > 0 ? std::sqrt(rr) / norm_b[c] : 0.0;
        result.residual = std::max(result.residual, relative);
        if (relative > o_.tolerance) active.push_back(c);
    }
    while (!active.empty() && result.iterations < o_.max_iterations) {
        ++result.iterations;
        multiply(A_, shared_, g, p, Ap, active, products);
        // Each channel's step on its own (the channels shared among the cores).
        const size_t n = active.size();
        std::vector<double> relative(n, -1.0);
        parallel_for(static_cast<int64_t>(n), [&](int64_t begin, int64_t end) {
            for (auto a = static_cast<size_t>(begin); a < static_cast<size_t>(end); ++a) {
                const int c = active[a];
                const double pAp = dot(p[c], Ap[c], owner);
                if (!(pAp > 0)) continue;  // converged to rounding
                const float step = static_cast<float>(rz[c] / pAp);
                float* __restrict rc = r[c].data();
                float* __restrict pc = p[c].data();
                const auto [rz_next, rr] = step_channel(step, x[c].data(), rc, pc, Ap[c].data(),
                                                        inverse.data(), owner.data(), size);
                const float beta = static_cast<float>(rz_next / rz[c]);
                rz[c] = rz_next;
                next_direction(beta, rc, inverse.data(), pc, size);
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
