#include "lifting.h"

#include "error.h"
#include "strings.h"

namespace tesswave {
namespace {

// Floating-point increments: the lifting rule as num / den.
template <class F>
struct RealRule {
    using T = F;
    using Acc = F;
    static F apply(F num, int64_t den) { return num / static_cast<F>(den); }
};
using FloatRule = RealRule<float>;
using DoubleRule = RealRule<double>;

// Integer increments rounded half up; floor division written out for negative numerators.
struct IntRule {
    using T = int32_t;
    using Acc = int64_t;
    static int32_t apply(int64_t num, int64_t den) {
        int64_t n = num + den / 2;
        int64_t q = n / den;
        return static_cast<int32_t>((n % den != 0 && n < 0) ? q - 1 : q);
    }
};

// Increments of the three steps for sample i of step `t` (T_{j+1} -> T_j). Each reads only
// points its step leaves unchanged, so forward adds and inverse subtracts the very same value.
template <class Rule>
struct Step {
    using T = typename Rule::T;
    using Acc = typename Rule::Acc;
    const LevelTopology& t;
    T* x;
    int32_t n, E;

    T face(int32_t k) const {  // f: (sum_v - 2 sum_e) / d
        Acc sv = 0, se = 0;
        const int32_t b = t.face_offsets[k], end = t.face_offsets[k + 1];
        for (int32_t c = b; c < end; ++c) {
            sv += x[t.face_v[c]];
            se += x[n + t.face_e[c]];
        }
        return Rule::apply(sv - 2 * se, end - b);
    }
    T edge(int32_t i) const {  // e: ((f0 + f1) - 2 (a + b)) / 4, curve: -(a + b) / 2
        const auto [a, b] = t.edge_v[i];
        const auto [f0, f1] = t.edge_f[i];
        const Acc sv = Acc{x[a]} + x[b];
        if (f1 == -1) return Rule::apply(-sv, 2);
        return Rule::apply(Acc{x[n + E + f0]} + x[n + E + f1] - 2 * sv, 4);
    }
    T vertex(int32_t v) const {  // v: (4 nf sum_e - ne sum_f) / (4 ne nf), curve: (e0 + e1) / 4
        if (t.kind[v] == PointKind::curve) {
            return Rule::apply(Acc{x[n + t.curve_e[v][0]]} + x[n + t.curve_e[v][1]], 4);
        }
        Acc se = 0, sf = 0;
        const int32_t e0 = t.star_e_offsets[v], e1 = t.star_e_offsets[v + 1];
        const int32_t f0 = t.star_f_offsets[v], f1 = t.star_f_offsets[v + 1];
        for (int32_t s = e0; s < e1; ++s) se += x[n + t.star_e[s]];
        for (int32_t s = f0; s < f1; ++s) sf += x[n + E + t.star_f[s]];
        const Acc ne = e1 - e0, nf = f1 - f0;
        return Rule::apply(4 * nf * se - ne * sf, 4 * ne * nf);
    }
};

template <class Rule>
void decompose(const LevelTopology& t, typename Rule::T* x) {
    Step<Rule> s{t, x, t.n_vertices, t.num_edges()};
    const int32_t F = t.num_faces();
    for (int32_t k = 0; k < F; ++k) x[s.n + s.E + k] += s.face(k);
    for (int32_t i = 0; i < s.E; ++i) x[s.n + i] += s.edge(i);
    for (int32_t v = 0; v < s.n; ++v) {
        if (t.kind[v] != PointKind::corner) x[v] += s.vertex(v);
    }
}

template <class Rule>
void reconstruct(const LevelTopology& t, typename Rule::T* x) {
    Step<Rule> s{t, x, t.n_vertices, t.num_edges()};
    const int32_t F = t.num_faces();
    for (int32_t v = 0; v < s.n; ++v) {
        if (t.kind[v] != PointKind::corner) x[v] -= s.vertex(v);
    }
    for (int32_t i = 0; i < s.E; ++i) x[s.n + i] -= s.edge(i);
    for (int32_t k = 0; k < F; ++k) x[s.n + s.E + k] -= s.face(k);
}

template <class T>
int checked_steps(const Hierarchy& h, std::span<const std::span<T>> planes,
                  const TransformOptions& options) {
    const int J = h.finest();
    const int steps = options.steps < 0 ? J : options.steps;
    if (steps > J)
        throw Error(str("transform: ", steps, " steps requested, the hierarchy has ", J));
    for (size_t c = 0; c < planes.size(); ++c) {
        if (planes[c].size() != static_cast<size_t>(h.num_samples(J))) {
            throw Error(str("transform: plane ", c, " has ", planes[c].size(), " values, level ", J,
                            " has ", h.num_samples(J), " samples"));
        }
    }
    return steps;
}

template <class Rule>
void forward(const Hierarchy& h, std::span<const std::span<typename Rule::T>> planes,
             const TransformOptions& options) {
    const int steps = checked_steps(h, planes, options);
    for (int j = h.finest() - 1; j >= h.finest() - steps; --j) {
        for (auto plane : planes) decompose<Rule>(h.levels[j], plane.data());
    }
}

template <class Rule>
void inverse(const Hierarchy& h, std::span<const std::span<typename Rule::T>> planes,
             const TransformOptions& options) {
    const int steps = checked_steps(h, planes, options);
    for (int j = h.finest() - steps; j < h.finest(); ++j) {
        for (auto plane : planes) reconstruct<Rule>(h.levels[j], plane.data());
    }
}

}  // namespace

void forward_transform(const Hierarchy& h, std::span<const std::span<float>> planes,
                       const TransformOptions& options) {
    forward<FloatRule>(h, planes, options);
}
void inverse_transform(const Hierarchy& h, std::span<const std::span<float>> planes,
                       const TransformOptions& options) {
    inverse<FloatRule>(h, planes, options);
}
void forward_transform(const Hierarchy& h, std::span<const std::span<double>> planes,
                       const TransformOptions& options) {
    forward<DoubleRule>(h, planes, options);
}
void inverse_transform(const Hierarchy& h, std::span<const std::span<double>> planes,
                       const TransformOptions& options) {
    inverse<DoubleRule>(h, planes, options);
}
void forward_transform_int(const Hierarchy& h, std::span<const std::span<int32_t>> planes,
                           const TransformOptions& options) {
    forward<IntRule>(h, planes, options);
}
void inverse_transform_int(const Hierarchy& h, std::span<const std::span<int32_t>> planes,
                           const TransformOptions& options) {
    inverse<IntRule>(h, planes, options);
}

}  // namespace tesswave
