// Internal: the lifting increments of DESIGN.md 2.4 (see lifting.h), written once for every
// kernel. The rounding of the integer rule and the evaluation order of the sums are part of the
// contract: every kernel must produce the very same bits as Step.
#pragma once

#include <cstdint>

#include "core/math/hierarchy.h"

namespace tesswave::detail {

// Floating-point increments: the lifting rule as num / den.
template <class F>
struct RealRule {
    using T = F;
    using Acc = F;
    static F apply(F num, int64_t den) { return num / static_cast<F>(den); }
};

// Integer increments num / den rounded half up, floor((num + floor(den/2)) / den), with the
// floor division written out for negative numerators. Sums are int64, so no stencil overflows.
// Samples are int32 (the codec) or int64 (inverting untrusted coefficients without overflow).
template <class I>
struct IntRuleOf {
    using T = I;
    using Acc = int64_t;
    static I apply(int64_t num, int64_t den) {
        const int64_t n = num + den / 2;
        const int64_t q = n / den;
        return static_cast<I>((n % den != 0 && n < 0) ? q - 1 : q);
    }
};
using IntRule = IntRuleOf<int32_t>;
using IntRule64 = IntRuleOf<int64_t>;

// Increments of the three steps for one point of step `t` (T_{j+1} -> T_j) on one plane. Each
// reads only points its step leaves unchanged, so forward adds and inverse subtracts the very
// same value. Sums run in the order of the tables (face corners and edges in cyclic order, vertex
// stars by increasing id), starting from zero.
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
    // The regular interior vertex (4 edges, 4 faces): the same expression with ne = nf = 4.
    static T regular_vertex(Acc se, Acc sf) { return Rule::apply(Acc{16} * se - Acc{4} * sf, 64); }
};

}  // namespace tesswave::detail
