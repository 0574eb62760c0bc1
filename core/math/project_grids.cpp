#include "core/math/project_grids.h"

#include <algorithm>
#include <cmath>

#include "core/math/parallel.h"

namespace tesswave::detail {
namespace {

// The kernels' bodies, inlined into one build per instruction set below. Each does its float and
// double operations in a fixed order (and the build has no fused multiply-add), so that every
// build gives the same bits.

// o[c] = sum over the nine entries e of st[e][c] g[c + offset[e]], c < n, each sum made in entry
// order; the rows vectorize 8 lanes wide where the machine has them.
[[gnu::always_inline]] inline void stencil_row_body(const float* const* st, const float* g,
                                                    const int32_t* offset, int32_t n,
                                                    float* __restrict o) {
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

// Adds (a[k] w[k]) b[k] to sum[k mod 4] for k < n: the four sums of dot and own_dot.
[[gnu::always_inline]] inline void add_products(double* __restrict sum, const float* __restrict a,
                                                const float* __restrict w,
                                                const float* __restrict b, size_t n) {
    const size_t whole = n - n % 4;
    for (size_t k = 0; k < whole; k += 4) {
        for (int i = 0; i < 4; ++i) sum[i] += static_cast<double>(a[k + i] * w[k + i]) * b[k + i];
    }
    for (size_t k = whole; k < n; ++k) sum[k % 4] += static_cast<double>(a[k] * w[k]) * b[k];
}

[[gnu::always_inline]] inline double dot_body(const float* __restrict a, const float* __restrict b,
                                              const float* __restrict owner, size_t n) {
    double sum[4] = {0, 0, 0, 0};
    add_products(sum, a, owner, b, n);
    return (sum[0] + sum[1]) + (sum[2] + sum[3]);
}

// dot_body with the weights 0 where shared[k] is set and 1 elsewhere. The weights are made 64 at
// a time first, so that both loops vectorize (a select inside the sum kept it scalar).
[[gnu::always_inline]] inline double own_dot_body(const float* __restrict a,
                                                  const float* __restrict b,
                                                  const uint8_t* __restrict shared, size_t n) {
    double sum[4] = {0, 0, 0, 0};
    constexpr size_t kBlock = 64;
    float own[kBlock];
    for (size_t from = 0; from < n; from += kBlock) {
        const size_t count = std::min(kBlock, n - from);
        for (size_t j = 0; j < count; ++j) own[j] = shared[from + j] == 0 ? 1.0f : 0.0f;
        add_products(sum, a + from, own, b + from, count);  // from is a multiple of 4
    }
    return (sum[0] + sum[1]) + (sum[2] + sum[3]);
}

[[gnu::always_inline]] inline std::pair<double, double> step_channel_body(
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

[[gnu::always_inline]] inline void next_direction_body(float beta, const float* __restrict r,
                                                       const float* __restrict inverse,
                                                       float* __restrict p, size_t n) {
    for (size_t k = 0; k < n; ++k) p[k] = r[k] * inverse[k] + beta * p[k];
}

[[gnu::always_inline]] inline double step_residual_body(float step, float* __restrict x,
                                                        float* __restrict r,
                                                        const float* __restrict p,
                                                        const float* __restrict ap,
                                                        const float* __restrict owner, size_t n) {
    double rr[4] = {0, 0, 0, 0};
    const size_t whole = n - n % 4;
    for (size_t k = 0; k < whole; k += 4) {
        for (int i = 0; i < 4; ++i) {
            x[k + i] += step * p[k + i];
            r[k + i] -= step * ap[k + i];
            rr[i] += static_cast<double>(r[k + i] * owner[k + i]) * r[k + i];
        }
    }
    for (size_t k = whole; k < n; ++k) {
        x[k] += step * p[k];
        r[k] -= step * ap[k];
        rr[k % 4] += static_cast<double>(r[k] * owner[k]) * r[k];
    }
    return (rr[0] + rr[1]) + (rr[2] + rr[3]);
}

[[gnu::always_inline]] inline void next_direction_from_body(float beta, const float* __restrict z,
                                                            float* __restrict p, size_t n) {
    for (size_t k = 0; k < n; ++k) p[k] = z[k] + beta * p[k];
}

// One build of the seven kernels per instruction set: TESSWAVE_KERNELS(suffix, attributes...).
#define TESSWAVE_KERNELS(suffix, ...)                                                          \
    __VA_ARGS__ void stencil_row_##suffix(const float* const* st, const float* g,              \
                                          const int32_t* offset, int32_t n, float* o) {        \
        stencil_row_body(st, g, offset, n, o);                                                 \
    }                                                                                          \
    __VA_ARGS__ double dot_##suffix(const float* a, const float* b, const float* owner,        \
                                    size_t n) {                                                \
        return dot_body(a, b, owner, n);                                                       \
    }                                                                                          \
    __VA_ARGS__ double own_dot_##suffix(const float* a, const float* b, const uint8_t* shared, \
                                        size_t n) {                                            \
        return own_dot_body(a, b, shared, n);                                                  \
    }                                                                                          \
    __VA_ARGS__ std::pair<double, double> step_channel_##suffix(                               \
        float step, float* x, float* r, const float* p, const float* ap, const float* inverse, \
        const float* owner, size_t n) {                                                        \
        return step_channel_body(step, x, r, p, ap, inverse, owner, n);                        \
    }                                                                                          \
    __VA_ARGS__ void next_direction_##suffix(float beta, const float* r, const float* inverse, \
                                             float* p, size_t n) {                             \
        next_direction_body(beta, r, inverse, p, n);                                           \
    }                                                                                          \
    __VA_ARGS__ double step_residual_##suffix(float step, float* x, float* r, const float* p,  \
                                              const float* ap, const float* owner, size_t n) { \
        return step_residual_body(step, x, r, p, ap, owner, n);                                \
    }                                                                                          \
    __VA_ARGS__ void next_direction_from_##suffix(float beta, const float* z, float* p,        \
                                                  size_t n) {                                  \
        next_direction_from_body(beta, z, p, n);                                               \
    }                                                                                          \
    constexpr VectorKernels kernels_##suffix = {stencil_row_##suffix,                          \
                                                dot_##suffix,                                  \
                                                own_dot_##suffix,                              \
                                                step_channel_##suffix,                         \
                                                next_direction_##suffix,                       \
                                                step_residual_##suffix,                        \
                                                next_direction_from_##suffix};

TESSWAVE_KERNELS(baseline)
#if defined(__x86_64__)
TESSWAVE_KERNELS(avx2, [[gnu::target("avx2")]])
#endif
#undef TESSWAVE_KERNELS

}  // namespace

const VectorKernels& baseline_kernels() { return kernels_baseline; }

const VectorKernels* avx2_kernels() {
#if defined(__x86_64__)
    if (__builtin_cpu_supports("avx2")) return &kernels_avx2;
#endif
    return nullptr;
}

const VectorKernels& vector_kernels() {
    static const VectorKernels& picked = avx2_kernels() ? *avx2_kernels() : baseline_kernels();
    return picked;
}

namespace {

// u . v over a quad's own (unshared) nodes, in four sums (node k in sum k mod 4), as dot adds.
// (One running sum in node order, a chain of dependent additions, was a fifth of the
// preconditioner's time.)
double own_dot(const float* u, const float* v, const uint8_t* shared, int32_t n) {
    return vector_kernels().own_dot(u, v, shared, static_cast<size_t>(n));
}

// The parts of multiply's and precondition's dot products: one per quad and one per shared
// sample, for each active channel, added in that order.
class OwnedDots {
  public:
    OwnedDots(const std::vector<double>* dots, size_t channels, size_t quads, size_t groups)
        : channels_(channels), stride_(quads + groups), quads_(quads) {
        if (dots) parts_.assign(channels * stride_, 0.0);
    }
    double& quad(size_t a, size_t q) { return parts_[a * stride_ + q]; }
    double& group(size_t a, int64_t i) {
        return parts_[a * stride_ + quads_ + static_cast<size_t>(i)];
    }
    void sum(std::vector<double>& dots) const {
        dots.assign(channels_, 0.0);
        for (size_t a = 0; a < channels_; ++a) {
            for (size_t i = 0; i < stride_; ++i) dots[a] += parts_[a * stride_ + i];
        }
    }

  private:
    size_t channels_, stride_, quads_;
    std::vector<double> parts_;
};

// The values of the shared samples after a pass that stashed each copy's part (`products`, one
// block of s.k.size() a channel): per sample, weight u plus the parts in quad order, written to
// every copy of out; with `parts`, u times that total at the first copy for the dot products.
void sum_shared(const LocalGrids& g, const std::vector<int>& active,
                const std::vector<float>& products, float weight, const Planes& u, Planes& out,
                OwnedDots* parts) {
    const size_t stride = g.copy.size();
    parallel_for(
        static_cast<int64_t>(g.offsets.size()) - 1,
        [&](int64_t begin, int64_t end) {
            for (size_t a = 0; a < active.size(); ++a) {
                const float* uc = u[active[a]].data();
                float* oc = out[active[a]].data();
                const float* stash = products.data() + a * stride;
                for (int64_t i = begin; i < end; ++i) {
                    const float first = uc[g.copy[g.offsets[i]]];
                    float total = weight == 0 ? 0.0f : weight * first;
                    for (int32_t j = g.offsets[i]; j < g.offsets[i + 1]; ++j)
                        total += stash[g.stashed[j]];
                    for (int32_t j = g.offsets[i]; j < g.offsets[i + 1]; ++j) oc[g.copy[j]] = total;
                    if (parts) parts->group(a, i) = double{first} * total;
                }
            }
        },
        1024);
}

}  // namespace

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
void add_stashed(const NormalMatrix& A, const SharedNodes& s, const float* stash, float* plane) {
    for (size_t q = 0; q < A.quads; ++q) {
        const int32_t* ids = A.grid + q * A.grid_size;
        for (int32_t i = s.offsets[q]; i < s.offsets[q + 1]; ++i) plane[ids[s.k[i]]] += stash[i];
    }
}

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

void multiply(const NormalMatrix& A, const SharedNodes& s, const LocalGrids& g, const Planes& x,
              Planes& y, const std::vector<int>& active, std::vector<float>& products,
              std::vector<double>* dots) {
    const int32_t side = g.side, grid_size = g.grid_size;
    const size_t n = active.size(), shared = s.k.size();
    products.resize(n * shared);
    OwnedDots parts(dots, n, A.quads, g.offsets.size() - 1);
    const float alpha = static_cast<float>(A.alpha);
    const VectorKernels& kernels = vector_kernels();
    const int32_t offset[9] = {-side - 1, -side, -side + 1, -1, 0, 1, side - 1, side, side + 1};
    parallel_for(static_cast<int64_t>(A.quads), [&](int64_t begin, int64_t end) {
        for (auto q = static_cast<size_t>(begin); q < static_cast<size_t>(end); ++q) {
            const float* st[9];
            for (int e = 0; e < 9; ++e) st[e] = A.entry(q, e);
            for (size_t a = 0; a < n; ++a) {
                const float* __restrict xq = x[active[a]].data() + g.index(q, 0);
                float* __restrict yq = y[active[a]].data() + g.index(q, 0);
                kernels.stencil_row(st, xq, offset, grid_size, yq);  // the whole grid as one row
                float* stash = products.data() + a * shared;
                for (int32_t i = s.offsets[q]; i < s.offsets[q + 1]; ++i) stash[i] = yq[s.k[i]];
                for (int32_t k = 0; k < grid_size; ++k) yq[k] = alpha * xq[k] + yq[k];
                if (dots)
                    parts.quad(a, q) = own_dot(xq, yq, s.shared.data() + q * grid_size, grid_size);
            }
        }
    });
    sum_shared(g, active, products, alpha, x, y, dots ? &parts : nullptr);
    if (dots) parts.sum(*dots);
}

// Cells a pixel above which a quad keeps Jacobi (project_grids.h).
constexpr double kLinesUpTo = 1.4;

LinePreconditioner make_line_preconditioner(const NormalMatrix& A, const LocalGrids& g) {
    LinePreconditioner m;
    const int32_t n = A.side;
    m.side = n;
    m.scale.assign(g.size, 0.0f);
    for (size_t q = 0; q < A.quads; ++q) {
        const int32_t* ids = A.grid + q * A.grid_size;
        for (int32_t k = 0; k < A.grid_size; ++k)
            m.scale[g.index(q, k)] = static_cast<float>(1.0 / std::sqrt(A.diagonal[ids[k]]));
    }
    for (size_t i = 0; i + 1 < g.offsets.size(); ++i) {
        const int32_t copies = g.offsets[i + 1] - g.offsets[i];
        for (int32_t j = g.offsets[i]; j < g.offsets[i + 1]; ++j)
            m.scale[g.copy[j]] *= static_cast<float>(1.0 / std::sqrt(copies));
    }
    m.factors.resize(A.quads * 2 * (1 + 2 * static_cast<size_t>(n)));
    m.solves.assign(A.quads, 0);
    parallel_for(static_cast<int64_t>(A.quads), [&](int64_t begin, int64_t end) {
        for (auto q = static_cast<size_t>(begin); q < static_cast<size_t>(end); ++q) {
            const int64_t cells = int64_t{n - 1} * (n - 1);
            if (static_cast<double>(cells) > kLinesUpTo * A.pixels[q]) continue;  // Jacobi
            m.solves[q] = 1;
            const int32_t* ids = A.grid + q * A.grid_size;
            double damping = 0;
            for (int32_t k = 0; k < A.grid_size; ++k) damping += A.alpha / A.diagonal[ids[k]];
            const double eps = std::sqrt(damping / A.grid_size);
            for (int direction = 0; direction < 2; ++direction) {
                const int32_t step = direction == 0 ? 1 : n;
                const float* coupling =
                    A.entry(q, direction == 0 ? stencil_entry(0, 1) : stencil_entry(1, 0));
                double sum = 0;
                int64_t count = 0;
                for (int32_t r = 0; r < n; ++r) {
                    for (int32_t c = 0; c < n; ++c) {
                        if ((direction == 0 ? c : r) + 1 >= n) continue;
                        const int32_t k = r * n + c;
                        sum +=
                            coupling[k] / std::sqrt(A.diagonal[ids[k]] * A.diagonal[ids[k + step]]);
                        ++count;
                    }
                }
                const double a = std::clamp(count > 0 ? sum / count : 0.0, -0.5, 0.5);
                const double diagonal = 1 + eps;
                float* f =
                    m.factors.data() + (q * 2 + direction) * (1 + 2 * static_cast<size_t>(n));
                float* multiplier = f + 1;
                float* inverse_pivot = f + 1 + n;
                f[0] = static_cast<float>(a);
                double pivot = diagonal;
                multiplier[0] = 0;
                inverse_pivot[0] = static_cast<float>(1 / pivot);
                for (int32_t i = 1; i < n; ++i) {
                    const double mi = a / pivot;
                    pivot = diagonal - mi * a;
                    multiplier[i] = static_cast<float>(mi);
                    inverse_pivot[i] = static_cast<float>(1 / pivot);
                }
            }
        }
    });
    m.any = std::find(m.solves.begin(), m.solves.end(), 1) != m.solves.end();
    return m;
}

namespace {

// u = (T + eps I)^-1 u along the columns of an n x n grid (each column a system, all columns at
// once, so the loops run along rows).
void solve_columns(const float* f, int32_t n, float* __restrict u) {
    const float* multiplier = f + 1;
    const float* inverse_pivot = f + 1 + n;
    for (int32_t r = 1; r < n; ++r) {
        const float m = multiplier[r];
        float* __restrict row = u + r * n;
        const float* __restrict above = row - n;
        for (int32_t c = 0; c < n; ++c) row[c] -= m * above[c];
    }
    for (int32_t c = 0; c < n; ++c) u[(n - 1) * n + c] *= inverse_pivot[n - 1];
    for (int32_t r = n - 2; r >= 0; --r) {
        const float ip = inverse_pivot[r], m = multiplier[r + 1];
        float* __restrict row = u + r * n;
        const float* __restrict below = row + n;
        for (int32_t c = 0; c < n; ++c) row[c] = row[c] * ip - m * below[c];
    }
}

// The same along the rows (each row a system; the rows are independent chains, interleaved).
void solve_rows(const float* f, int32_t n, float* __restrict u) {
    const float* multiplier = f + 1;
    const float* inverse_pivot = f + 1 + n;
    for (int32_t c = 1; c < n; ++c) {
        const float m = multiplier[c];
        for (int32_t r = 0; r < n; ++r) u[r * n + c] -= m * u[r * n + c - 1];
    }
    for (int32_t r = 0; r < n; ++r) u[r * n + n - 1] *= inverse_pivot[n - 1];
    for (int32_t c = n - 2; c >= 0; --c) {
        const float ip = inverse_pivot[c], m = multiplier[c + 1];
        for (int32_t r = 0; r < n; ++r) u[r * n + c] = u[r * n + c] * ip - m * u[r * n + c + 1];
    }
}

}  // namespace

void precondition(const NormalMatrix& A, const SharedNodes& s, const LocalGrids& g,
                  const LinePreconditioner& m, const Planes& r, Planes& z,
                  const std::vector<int>& active, std::vector<float>& products,
                  std::vector<double>* dots) {
    const int32_t n = A.side, grid_size = A.grid_size;
    const size_t count = active.size(), shared = s.k.size();
    products.resize(count * shared);
    OwnedDots parts(dots, count, A.quads, g.offsets.size() - 1);
    parallel_for(static_cast<int64_t>(A.quads), [&](int64_t begin, int64_t end) {
        std::vector<float> u(static_cast<size_t>(grid_size));
        for (auto q = static_cast<size_t>(begin); q < static_cast<size_t>(end); ++q) {
            const float* scale = m.scale.data() + g.index(q, 0);
            for (size_t a = 0; a < count; ++a) {
                const float* rq = r[active[a]].data() + g.index(q, 0);
                float* zq = z[active[a]].data() + g.index(q, 0);
                if (m.solves[q]) {
                    for (int32_t k = 0; k < grid_size; ++k) u[k] = scale[k] * rq[k];
                    solve_rows(m.of(q, 0), n, u.data());
                    solve_columns(m.of(q, 1), n, u.data());
                    for (int32_t k = 0; k < grid_size; ++k) zq[k] = scale[k] * u[k];
                } else {
                    for (int32_t k = 0; k < grid_size; ++k) zq[k] = scale[k] * (scale[k] * rq[k]);
                }
                if (dots)
                    parts.quad(a, q) = own_dot(rq, zq, s.shared.data() + q * grid_size, grid_size);
                float* stash = products.data() + a * shared;
                for (int32_t i = s.offsets[q]; i < s.offsets[q + 1]; ++i) stash[i] = zq[s.k[i]];
            }
        }
    });
    sum_shared(g, active, products, 0.0f, r, z, dots ? &parts : nullptr);
    if (dots) parts.sum(*dots);
}

double dot(const std::vector<float>& a, const std::vector<float>& b,
           const std::vector<float>& owner) {
    return vector_kernels().dot(a.data(), b.data(), owner.data(), a.size());
}

}  // namespace tesswave::detail
