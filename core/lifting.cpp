#include "lifting.h"

#include <algorithm>
#include <array>

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
// Samples are S values apart (S = 1: a plane; S = C: C interleaved channels).
template <class Rule, int S = 1>
struct Step {
    using T = typename Rule::T;
    using Acc = typename Rule::Acc;
    const LevelTopology& t;
    T* x;
    int32_t n, E;

    T& at(int32_t i) const { return x[static_cast<size_t>(i) * S]; }

    T face(int32_t k) const {  // f: (sum_v - 2 sum_e) / d
        Acc sv = 0, se = 0;
        const int32_t b = t.face_offsets[k], end = t.face_offsets[k + 1];
        for (int32_t c = b; c < end; ++c) {
            sv += at(t.face_v[c]);
            se += at(n + t.face_e[c]);
        }
        return Rule::apply(sv - 2 * se, end - b);
    }
    T edge(int32_t i) const {  // e: ((f0 + f1) - 2 (a + b)) / 4, curve: -(a + b) / 2
        const auto [a, b] = t.edge_v[i];
        const auto [f0, f1] = t.edge_f[i];
        const Acc sv = Acc{at(a)} + at(b);
        if (f1 == -1) return Rule::apply(-sv, 2);
        return Rule::apply(Acc{at(n + E + f0)} + at(n + E + f1) - 2 * sv, 4);
    }
    T vertex(int32_t v) const {  // v: (4 nf sum_e - ne sum_f) / (4 ne nf), curve: (e0 + e1) / 4
        if (t.kind[v] == PointKind::curve) {
            return Rule::apply(Acc{at(n + t.curve_e[v][0])} + at(n + t.curve_e[v][1]), 4);
        }
        Acc se = 0, sf = 0;
        const int32_t e0 = t.star_e_offsets[v], e1 = t.star_e_offsets[v + 1];
        const int32_t f0 = t.star_f_offsets[v], f1 = t.star_f_offsets[v + 1];
        for (int32_t s = e0; s < e1; ++s) se += at(n + t.star_e[s]);
        for (int32_t s = f0; s < f1; ++s) sf += at(n + E + t.star_f[s]);
        const Acc ne = e1 - e0, nf = f1 - f0;
        return Rule::apply(4 * nf * se - ne * sf, 4 * ne * nf);
    }
};

// The reference: one plane at a time, each point through Step.
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

// The fast kernel works on C interleaved channels, so one neighbour's values share a cache line;
// quads and regular vertices use fixed-width tables. The expressions and their order are those
// of Step, so results are bit-identical to the reference. kSign: +1 decompose, -1 reconstruct.
template <class Rule, int C>
struct FastStep {
    using T = typename Rule::T;
    using Acc = typename Rule::Acc;
    const LevelTopology& t;
    T* x;  // interleaved: sample i, channel c at x[i * C + c]
    int32_t n, E;

    T* at(int32_t i) const { return x + static_cast<size_t>(i) * C; }

    template <int kSign>
    void faces() const {
        const int32_t F = t.num_faces();
        if (t.face_v.size() != static_cast<size_t>(4) * F) {  // T0 polygons: the plain rule
            for (int c = 0; c < C; ++c) {
                Step<Rule, C> s{t, x + c, n, E};
                for (int32_t k = 0; k < F; ++k) s.at(n + E + k) += kSign * s.face(k);
            }
            return;
        }
        const int32_t* fv = t.face_v.data();
        const int32_t* fe = t.face_e.data();
        for (int32_t k = 0; k < F; ++k, fv += 4, fe += 4) {
            const T *v0 = at(fv[0]), *v1 = at(fv[1]), *v2 = at(fv[2]), *v3 = at(fv[3]);
            const T *e0 = at(n + fe[0]), *e1 = at(n + fe[1]), *e2 = at(n + fe[2]),
                    *e3 = at(n + fe[3]);
            T* f = at(n + E + k);
            for (int c = 0; c < C; ++c) {
                const Acc sv = Acc{0} + v0[c] + v1[c] + v2[c] + v3[c];
                const Acc se = Acc{0} + e0[c] + e1[c] + e2[c] + e3[c];
                f[c] += kSign * Rule::apply(sv - 2 * se, 4);
            }
        }
    }

    template <int kSign>
    void edges() const {
        for (int32_t i = 0; i < E; ++i) {
            const auto [a, b] = t.edge_v[i];
            const auto [f0, f1] = t.edge_f[i];
            const T *va = at(a), *vb = at(b);
            T* e = at(n + i);
            if (f1 == -1) {
                for (int c = 0; c < C; ++c) e[c] += kSign * Rule::apply(-(Acc{va[c]} + vb[c]), 2);
            } else {
                const T *g0 = at(n + E + f0), *g1 = at(n + E + f1);
                for (int c = 0; c < C; ++c) {
                    const Acc sv = Acc{va[c]} + vb[c];
                    e[c] += kSign * Rule::apply(Acc{g0[c]} + g1[c] - 2 * sv, 4);
                }
            }
        }
    }

    template <int kSign>
    void vertices() const {
        const size_t regular = t.v_regular.size();
        for (size_t r = 0; r < regular; ++r) {
            const auto& nb = t.v_regular_nb[r];
            const T *e0 = at(nb[0]), *e1 = at(nb[1]), *e2 = at(nb[2]), *e3 = at(nb[3]);
            const T *f0 = at(nb[4]), *f1 = at(nb[5]), *f2 = at(nb[6]), *f3 = at(nb[7]);
            T* v = at(t.v_regular[r]);
            for (int c = 0; c < C; ++c) {
                const Acc se = Acc{0} + e0[c] + e1[c] + e2[c] + e3[c];
                const Acc sf = Acc{0} + f0[c] + f1[c] + f2[c] + f3[c];
                v[c] += kSign * Rule::apply(Acc{16} * se - Acc{4} * sf, 64);
            }
        }
        for (int c = 0; c < C; ++c) {
            Step<Rule, C> s{t, x + c, n, E};
            for (int32_t v : t.v_irregular) s.at(v) += kSign * s.vertex(v);
            for (int32_t v : t.v_curve) s.at(v) += kSign * s.vertex(v);
        }
    }
};

// Interleaves C planes into a scratch buffer, runs the levels, and writes the planes back.
template <class Rule, int C>
void fast_levels(const Hierarchy& h, std::span<const std::span<typename Rule::T>> planes, int first,
                 int last, bool forward) {
    const int used = static_cast<int>(planes.size());
    using T = typename Rule::T;
    const size_t n = planes[0].size();
    // One scratch buffer per thread and type, kept between calls: a fresh 100 MB buffer would
    // cost more in page faults than the transform itself.
    thread_local HugeVector<T> scratch;
    if (scratch.size() < n * C) {
        scratch = HugeVector<T>();
        scratch.resize(n * C);
    }
    T* x = scratch.data();
    for (size_t i = 0; i < n; ++i) {
        for (int c = 0; c < C; ++c) x[i * C + c] = c < used ? planes[c][i] : T{0};
    }
    for (int s = 0; s < last - first; ++s) {
        const int j = forward ? last - 1 - s : first + s;
        const LevelTopology& t = h.levels[j];
        FastStep<Rule, C> step{t, x, t.n_vertices, t.num_edges()};
        if (forward) {
            step.template faces<1>();
            step.template edges<1>();
            step.template vertices<1>();
        } else {
            step.template vertices<-1>();
            step.template edges<-1>();
            step.template faces<-1>();
        }
    }
    for (size_t i = 0; i < n; ++i) {
        for (int c = 0; c < used; ++c) planes[c][i] = x[i * C + c];
    }
}

// Steps between levels `first` and `last` (forward: last -> first). Channels go through the fast
// kernel in groups of up to four.
template <class Rule>
void run_levels(const Hierarchy& h, std::span<const std::span<typename Rule::T>> planes, int first,
                int last, bool forward, LiftingKernel kernel) {
    if (kernel == LiftingKernel::reference) {
        for (int s = 0; s < last - first; ++s) {
            const int j = forward ? last - 1 - s : first + s;
            for (auto plane : planes) {
                forward ? decompose<Rule>(h.levels[j], plane.data())
                        : reconstruct<Rule>(h.levels[j], plane.data());
            }
        }
        return;
    }
    for (size_t c = 0; c < planes.size(); c += 4) {
        auto group = planes.subspan(c, std::min<size_t>(4, planes.size() - c));
        switch (group.size()) {
            case 1:
                fast_levels<Rule, 1>(h, group, first, last, forward);
                break;
            case 2:
                fast_levels<Rule, 2>(h, group, first, last, forward);
                break;
            case 3:
                fast_levels<Rule, 3>(h, group, first, last, forward);
                break;
            default:
                fast_levels<Rule, 4>(h, group, first, last, forward);
                break;
        }
    }
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
    run_levels<Rule>(h, planes, h.finest() - steps, h.finest(), true, options.kernel);
}

template <class Rule>
void inverse(const Hierarchy& h, std::span<const std::span<typename Rule::T>> planes,
             const TransformOptions& options) {
    const int steps = checked_steps(h, planes, options);
    run_levels<Rule>(h, planes, h.finest() - steps, h.finest(), false, options.kernel);
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
