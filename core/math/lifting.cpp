#include "core/math/lifting.h"

#include <algorithm>

#include "core/math/error.h"
#include "core/math/lifting_patch.h"
#include "core/math/lifting_rules.h"
#include "core/math/parallel.h"
#include "core/math/patch_grid.h"
#include "core/math/strings.h"

namespace tesswave {
namespace {

using detail::IntRule;
using detail::IntRule64;
using detail::PatchSides;
using detail::PatchStep;
using detail::Step;
using DoubleRule = detail::RealRule<double>;
using FloatRule = detail::RealRule<float>;

// The reference: every point through Step, one at a time.
template <class Rule>
void reference_step(const LevelTopology& t, typename Rule::T* x, bool forward) {
    Step<Rule> s{t, x, t.n_vertices, t.num_edges()};
    const int32_t F = t.num_faces();
    const int sign = forward ? 1 : -1;
    auto faces = [&] {
        for (int32_t k = 0; k < F; ++k) x[s.n + s.E + k] += sign * s.face(k);
    };
    auto edges = [&] {
        for (int32_t i = 0; i < s.E; ++i) x[s.n + i] += sign * s.edge(i);
    };
    auto vertices = [&] {
        for (int32_t v = 0; v < s.n; ++v) {
            if (t.kind[v] != PointKind::corner) x[v] += sign * s.vertex(v);
        }
    };
    if (forward) {
        faces(), edges(), vertices();
    } else {
        vertices(), edges(), faces();
    }
}

// Table-driven points: all of T0 and T1, and the skeleton (the T1 edges) of finer levels.
// Regular vertices use their fixed-width neighbour table; everything else goes through Step.
template <class Rule>
struct TableStep {
    using T = typename Rule::T;
    using Acc = typename Rule::Acc;
    Step<Rule> s;
    int sign;

    // Each pass writes points of one kind and reads only the other kinds, so its points are
    // shared among the cores in any order: the same bits.
    static constexpr int64_t kPiece = 8192;

    void faces() const {
        parallel_for(
            s.t.num_faces(),
            [&](int64_t begin, int64_t end) {
                for (auto k = static_cast<int32_t>(begin); k < end; ++k)
                    s.x[s.n + s.E + k] += sign * s.face(k);
            },
            kPiece);
    }
    void edges(int32_t count) const {
        parallel_for(
            count,
            [&](int64_t begin, int64_t end) {
                for (auto i = static_cast<int32_t>(begin); i < end; ++i)
                    s.x[s.n + i] += sign * s.edge(i);
            },
            kPiece);
    }
    void vertices() const {
        const LevelTopology& t = s.t;
        T* x = s.x;
        const auto regular = static_cast<int64_t>(t.v_regular.size());
        const auto irregular = static_cast<int64_t>(t.v_irregular.size());
        const auto curve = static_cast<int64_t>(t.v_curve.size());
        parallel_for(
            regular + irregular + curve,
            [&](int64_t begin, int64_t end) {
                for (int64_t r = begin; r < std::min(end, regular); ++r) {
                    const auto& nb = t.v_regular_nb[r];
                    const Acc se = Acc{0} + x[nb[0]] + x[nb[1]] + x[nb[2]] + x[nb[3]];
                    const Acc sf = Acc{0} + x[nb[4]] + x[nb[5]] + x[nb[6]] + x[nb[7]];
                    x[t.v_regular[r]] += sign * Step<Rule>::regular_vertex(se, sf);
                }
                for (int64_t i = std::max(begin, regular); i < end; ++i) {
                    const int32_t v = i < regular + irregular ? t.v_irregular[i - regular]
                                                              : t.v_curve[i - regular - irregular];
                    x[v] += sign * s.vertex(v);
                }
            },
            kPiece);
    }
};

// The fast step: patch interiors by rows (levels with m >= 2), the rest by tables. A patch's
// interior points depend only on its own faces, its interior edges and the skeleton vertices
// around it, so each patch runs f', e', v' in one go, row by row (PatchStep::run):
//   forward: per patch f', interior e', interior v'; then skeleton e' (its faces are done and its
//            endpoints untouched), then skeleton v' (every e' and f' is done);
//   inverse: skeleton v', skeleton e' (they read only primed values and restored skeleton
//            vertices), then per patch interior v', interior e', f'.
template <class Rule>
void fast_step(const LevelTopology& t, const PatchSides& ps, typename Rule::T* x, bool forward) {
    const TableStep<Rule> table{{t, x, t.n_vertices, t.num_edges()}, forward ? 1 : -1};
    if (t.patch_cells < 2) {
        if (forward) {
            table.faces(), table.edges(t.num_edges()), table.vertices();
        } else {
            table.vertices(), table.edges(t.num_edges()), table.faces();
        }
        return;
    }
    const int32_t P = static_cast<int32_t>(ps.sides.size());
    const int32_t skeleton_edges = ps.num_t1_edges * t.patch_cells;
    // Patches touch only their own interiors: the cores take a share each, with a PatchStep (its
    // row buffers) apiece. A patch's work grows with m^2; pieces of at least 4096 points.
    const int64_t min_patches =
        std::max<int64_t>(1, 4096 / (int64_t{t.patch_cells} * t.patch_cells));
    auto patches = [&](auto&& one) {
        parallel_for(
            P,
            [&](int64_t begin, int64_t end) {
                PatchStep<Rule> patch(t, ps, x);
                for (int64_t p = begin; p < end; ++p) one(patch, static_cast<int32_t>(p));
            },
            min_patches);
    };
    if (forward) {
        patches([](PatchStep<Rule>& patch, int32_t p) { patch.template run<1>(p); });
        table.edges(skeleton_edges);
        table.vertices();
    } else {
        table.vertices();
        table.edges(skeleton_edges);
        patches([](PatchStep<Rule>& patch, int32_t p) { patch.template run<-1>(p); });
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
void run(const Hierarchy& h, std::span<const std::span<typename Rule::T>> planes,
         const TransformOptions& options, bool forward) {
    const int steps = checked_steps(h, planes, options);
    const PatchSides ps = h.finest() >= 1 ? detail::patch_sides(h.levels[1]) : PatchSides{};
    for (auto plane : planes) {
        for (int s = 0; s < steps; ++s) {
            const int j = forward ? h.finest() - 1 - s : h.finest() - steps + s;
            if (options.kernel == LiftingKernel::reference) {
                reference_step<Rule>(h.levels[j], plane.data(), forward);
            } else {
                fast_step<Rule>(h.levels[j], ps, plane.data(), forward);
            }
        }
    }
}

}  // namespace

void forward_transform(const Hierarchy& h, std::span<const std::span<float>> planes,
                       const TransformOptions& options) {
    run<FloatRule>(h, planes, options, true);
}
void inverse_transform(const Hierarchy& h, std::span<const std::span<float>> planes,
                       const TransformOptions& options) {
    run<FloatRule>(h, planes, options, false);
}
void forward_transform(const Hierarchy& h, std::span<const std::span<double>> planes,
                       const TransformOptions& options) {
    run<DoubleRule>(h, planes, options, true);
}
void inverse_transform(const Hierarchy& h, std::span<const std::span<double>> planes,
                       const TransformOptions& options) {
    run<DoubleRule>(h, planes, options, false);
}
void forward_transform_int(const Hierarchy& h, std::span<const std::span<int32_t>> planes,
                           const TransformOptions& options) {
    run<IntRule>(h, planes, options, true);
}
void inverse_transform_int(const Hierarchy& h, std::span<const std::span<int32_t>> planes,
                           const TransformOptions& options) {
    run<IntRule>(h, planes, options, false);
}

void inverse_transform_int(const Hierarchy& h, std::span<const std::span<int64_t>> planes,
                           const TransformOptions& options) {
    run<IntRule64>(h, planes, options, false);
}

}  // namespace tesswave
