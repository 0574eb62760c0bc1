#include "core/math/project_grids.h"

#include <algorithm>

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

[[gnu::always_inline]] inline double dot_body(const float* __restrict a, const float* __restrict b,
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

// One build of the four kernels per instruction set: TESSWAVE_KERNELS(suffix, attributes...).
#define TESSWAVE_KERNELS(suffix, ...)                                                          \
    __VA_ARGS__ void stencil_row_##suffix(const float* const* st, const float* g,              \
                                          const int32_t* offset, int32_t n, float* o) {        \
        stencil_row_body(st, g, offset, n, o);                                                 \
    }                                                                                          \
    __VA_ARGS__ double dot_##suffix(const float* a, const float* b, const float* owner,        \
                                    size_t n) {                                                \
        return dot_body(a, b, owner, n);                                                       \
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
    constexpr VectorKernels kernels_##suffix = {stencil_row_##suffix, dot_##suffix,            \
                                                step_channel_##suffix, next_direction_##suffix};

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
              Planes& y, const std::vector<int>& active, std::vector<float>& products) {
    const int32_t side = g.side, grid_size = g.grid_size;
    const size_t n = active.size(), shared = s.k.size();
    products.resize(n * shared);
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

double dot(const std::vector<float>& a, const std::vector<float>& b,
           const std::vector<float>& owner) {
    return vector_kernels().dot(a.data(), b.data(), owner.data(), a.size());
}

}  // namespace tesswave::detail
