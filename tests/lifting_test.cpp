#include "core/math/lifting.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>

#include "core/math/error.h"
#include "core/math/grid_mesh.h"
#include "core/math/parallel.h"
#include "core/math/triangulate.h"
#include "core/math/voronoi.h"
#include "samples/sample_meshes.h"
#include "test_meshes.h"

namespace tesswave {
namespace {

using testing::uniform;

struct NamedMesh {
    const char* name;
    Mesh mesh;
};

// Features crossing the whole paper mesh, left border to right border: two components.
Mesh paper_with_crossing_feature() {
    Mesh mesh = samples::paper_t0(120, 90);
    mesh.features = {{5, 6}, {6, 7}, {7, 8}, {8, 9}};
    return mesh;
}

std::vector<NamedMesh> test_meshes() {
    std::vector<Vec2> points;
    std::mt19937_64 rng(3);
    for (int i = 0; i < 12; ++i) points.push_back({5 + 90 * uniform(rng), 5 + 70 * uniform(rng)});
    std::vector<NamedMesh> out = {
        {"one square", grid_mesh(8, 8, 1, 1)},
        {"grid 3x2", grid_mesh(30, 20, 3, 2)},
        {"deformed grid", testing::deformed_grid(50, 40, 4, 3, 0.22, 11)},
        {"paper", samples::paper_t0(249, 251)},
        {"paper + feature end", samples::paper_t0_with_features(100, 80)},
        {"paper + crossing feature", paper_with_crossing_feature()},
        {"voronoi", voronoi_mesh(100, 80, {.sites = 12, .seed = 5, .lloyd_iterations = 1})},
        {"triangulation", triangulate_points(100, 80, points, {.border_points_per_side = 2})},
    };
    Mesh junction = samples::paper_t0(100, 80);
    junction.features = {{6, 7}, {7, 8}, {7, 12}, {11, 12}};
    out.push_back({"feature junction", junction});
    return out;
}

TEST(Lifting, perfect_reconstruction_float_and_double) {
    for (auto& [name, mesh] : test_meshes()) {
        SCOPED_TRACE(name);
        testing::expect_valid(mesh);
        const Hierarchy h = build_hierarchy(mesh, {.levels = 4});
        const size_t n = h.num_samples(4);
        std::mt19937_64 rng(1);
        std::vector<float> r(n), g(n), b(n);
        std::vector<double> d(n);
        for (size_t i = 0; i < n; ++i) {
            r[i] = static_cast<float>(255 * uniform(rng));
            g[i] = static_cast<float>(255 * uniform(rng));
            b[i] = static_cast<float>(255 * uniform(rng));
            d[i] = r[i];
        }
        const auto r0 = r, g0 = g, b0 = b;
        std::span<float> planes[] = {r, g, b};
        forward_transform(h, planes);
        EXPECT_NE(r, r0);
        inverse_transform(h, planes);
        for (size_t i = 0; i < n; ++i) {
            ASSERT_NEAR(r[i], r0[i], 255 * 2e-6) << i;
            ASSERT_NEAR(g[i], g0[i], 255 * 2e-6) << i;
            ASSERT_NEAR(b[i], b0[i], 255 * 2e-6) << i;
        }
        std::span<double> dp[] = {d};
        forward_transform(h, dp);
        inverse_transform(h, dp);
        for (size_t i = 0; i < n; ++i) ASSERT_NEAR(d[i], r0[i], 1e-10);
    }
}

TEST(Lifting, integer_variant_is_bit_exact) {
    for (auto& [name, mesh] : test_meshes()) {
        SCOPED_TRACE(name);
        const Hierarchy h = build_hierarchy(mesh, {.levels = 4});
        const size_t n = h.num_samples(4);
        std::mt19937_64 rng(2);
        std::vector<int32_t> a(n), b(n);
        for (size_t i = 0; i < n; ++i) {
            a[i] = static_cast<int32_t>(rng() % 65536) - 32768;
            b[i] = static_cast<int32_t>(rng() % 256);
        }
        const auto a0 = a, b0 = b;
        std::span<int32_t> planes[] = {a, b};
        forward_transform_int(h, planes);
        EXPECT_NE(a, a0);
        inverse_transform_int(h, planes);
        EXPECT_EQ(a, a0);
        EXPECT_EQ(b, b0);
        // Partial decompositions are exact too.
        forward_transform_int(h, planes, {.steps = 2});
        inverse_transform_int(h, planes, {.steps = 2});
        EXPECT_EQ(a, a0);
    }
}

TEST(Lifting, integer_inverse_in_int64_matches_int32) {
    for (auto& [name, mesh] : test_meshes()) {
        SCOPED_TRACE(name);
        const Hierarchy h = build_hierarchy(mesh, {.levels = 4});
        std::mt19937_64 rng(5);
        std::vector<int32_t> a(h.num_samples(4));
        for (int32_t& v : a) v = static_cast<int32_t>(rng() % 4096) - 2048;  // any coefficients
        std::vector<int64_t> wide(a.begin(), a.end());
        std::span<int32_t> narrow[] = {a};
        std::span<int64_t> planes64[] = {wide};
        inverse_transform_int(h, narrow);
        inverse_transform_int(h, planes64);
        EXPECT_EQ(std::vector<int64_t>(a.begin(), a.end()), wide);
    }
}

// Component of each finest-level sample when the cut mesh falls apart along features: flood fill
// the T0 faces, then follow each face to its children (face k's children are its corner quads).
std::vector<int> sample_components(const Hierarchy& h) {
    const LevelTopology& t0 = h.levels[0];
    std::vector<int> comp(t0.num_faces(), -1);
    int next = 0;
    for (int32_t seed = 0; seed < t0.num_faces(); ++seed) {
        if (comp[seed] != -1) continue;
        std::vector<int32_t> stack{seed};
        comp[seed] = next;
        while (!stack.empty()) {
            int32_t f = stack.back();
            stack.pop_back();
            for (int32_t c = t0.face_offsets[f]; c < t0.face_offsets[f + 1]; ++c) {
                for (int32_t g : t0.edge_f[t0.face_e[c]]) {
                    if (g >= 0 && comp[g] == -1) comp[g] = next, stack.push_back(g);
                }
            }
        }
        ++next;
    }
    for (int j = 0; j < h.finest(); ++j) {
        const LevelTopology& t = h.levels[j];
        std::vector<int> fine(t.face_v.size());
        for (int32_t k = 0; k < t.num_faces(); ++k) {
            for (int32_t q = t.face_offsets[k]; q < t.face_offsets[k + 1]; ++q) fine[q] = comp[k];
        }
        comp = std::move(fine);
    }
    const LevelTopology& top = h.levels[h.finest()];
    std::vector<int> out(top.n_vertices, -1);
    for (int32_t k = 0; k < top.num_faces(); ++k) {
        for (int32_t c = top.face_offsets[k]; c < top.face_offsets[k + 1]; ++c) {
            out[top.face_v[c]] = comp[k];
        }
    }
    return out;
}

TEST(Lifting, linear_precision_on_deformed_meshes_boundaries_and_features) {
    for (auto& [name, mesh] : test_meshes()) {
        SCOPED_TRACE(name);
        const int J = 4;
        const Hierarchy h = build_hierarchy(mesh, {.levels = J});
        const auto p = refine_positions(h, mesh.vertices, J);
        const auto comp = sample_components(h);
        // A different linear function on each side of the features (one side when they do not
        // cut the domain apart): the samples on a feature carry both, one per side.
        auto f = [](int side, Vec2 q) {
            return side == 0 ? 3.0 + 0.7 * q.x - 1.3 * q.y : -20.0 - 0.4 * q.x + 2.1 * q.y;
        };
        std::vector<double> x(p.size());
        for (size_t i = 0; i < p.size(); ++i) x[i] = f(comp[i], p[i]);
        std::span<double> planes[] = {x};
        forward_transform(h, planes);
        const int32_t n0 = h.num_samples(0);
        for (size_t i = n0; i < x.size(); ++i) ASSERT_NEAR(x[i], 0.0, 1e-10) << "detail " << i;
        for (int32_t i = 0; i < n0; ++i)
            ASSERT_NEAR(x[i], f(comp[i], p[i]), 1e-10) << "vertex " << i;
    }
}

TEST(Lifting, corners_are_never_modified) {
    const Mesh mesh = samples::paper_t0_with_features(100, 80);
    const Hierarchy h = build_hierarchy(mesh, {.levels = 3});
    std::vector<double> x(h.num_samples(3));
    std::mt19937_64 rng(4);
    for (double& v : x) v = uniform(rng);
    const auto x0 = x;
    std::span<double> planes[] = {x};
    forward_transform(h, planes);
    for (int32_t i = 0; i < h.num_samples(0); ++i) {
        if (h.levels[0].kind[i] == PointKind::corner)
            EXPECT_EQ(x[i], x0[i]) << i;
        else
            EXPECT_NE(x[i], x0[i]) << i;
    }
}

// DESIGN.md 2.4: on a regular grid, away from the border, one step equals the separable
// LeGall 5/3 lifting (e -= (l + r)/2; v += (l' + r')/4) along x, then along y.
TEST(Lifting, regular_grid_step_equals_separable_cdf53) {
    const int J = 3, cols = 5, rows = 4, s = 1 << J;
    const Mesh mesh = grid_mesh(cols * s, rows * s, cols, rows);
    const Hierarchy h = build_hierarchy(mesh, {.levels = J});
    const auto p = refine_positions(h, mesh.vertices, J);
    const int W = cols * s + 1, H = rows * s + 1;
    std::vector<double> lattice(W * H), x(p.size());
    std::mt19937_64 rng(5);
    for (double& v : lattice) v = uniform(rng) * 100;
    std::vector<int32_t> id(W * H, -1);
    for (size_t i = 0; i < p.size(); ++i) {
        const int xi = static_cast<int>(p[i].x), yi = static_cast<int>(p[i].y);
        ASSERT_EQ(p[i].x, xi);
        ASSERT_EQ(p[i].y, yi);
        id[yi * W + xi] = static_cast<int32_t>(i);
        x[i] = lattice[yi * W + xi];
    }
    std::span<double> planes[] = {x};
    forward_transform(h, planes, {.steps = 1});
    auto lift = [&](int stride, int count, int step, int start) {
        for (int k = 1; k < count - 1; k += 2) {
            double& e = lattice[start + k * step];
            e -= 0.5 * (lattice[start + (k - 1) * step] + lattice[start + (k + 1) * step]);
        }
        for (int k = 2; k < count - 1; k += 2) {
            double& v = lattice[start + k * step];
            v += 0.25 * (lattice[start + (k - 1) * step] + lattice[start + (k + 1) * step]);
        }
        (void)stride;
    };
    for (int y = 0; y < H; ++y) lift(1, W, 1, y * W);
    for (int c = 0; c < W; ++c) lift(W, H, W, c);
    int compared = 0;
    for (int y = 3; y < H - 3; ++y) {
        for (int c = 3; c < W - 3; ++c) {
            ASSERT_NEAR(x[id[y * W + c]], lattice[y * W + c], 1e-12) << c << "," << y;
            ++compared;
        }
    }
    EXPECT_GT(compared, 600);
}

// The fast kernel evaluates the reference's expressions in the same order: identical bits, in
// float and in integers, forward and inverse, for any channel count (groups of up to four).
TEST(Lifting, fast_kernel_equals_reference_bit_for_bit) {
    for (auto& [name, mesh] : test_meshes()) {
        SCOPED_TRACE(name);
        const Hierarchy h = build_hierarchy(mesh, {.levels = 4});
        const size_t n = h.num_samples(4);
        std::mt19937_64 rng(6);
        for (int channels : {1, 3, 5}) {
            std::vector<std::vector<float>> fast(channels, std::vector<float>(n));
            std::vector<std::vector<int32_t>> ifast(channels, std::vector<int32_t>(n));
            for (int c = 0; c < channels; ++c) {
                for (size_t i = 0; i < n; ++i) {
                    fast[c][i] = static_cast<float>(uniform(rng) * 255);
                    ifast[c][i] = static_cast<int32_t>(rng() % 4096) - 2048;
                }
            }
            auto ref = fast;
            auto iref = ifast;
            std::vector<std::span<float>> fs(fast.begin(), fast.end()), rs(ref.begin(), ref.end());
            std::vector<std::span<int32_t>> ifs(ifast.begin(), ifast.end()),
                irs(iref.begin(), iref.end());
            forward_transform(h, fs);
            forward_transform(h, rs, {.kernel = LiftingKernel::reference});
            ASSERT_EQ(fast, ref) << channels << " channels, forward";
            forward_transform_int(h, ifs);
            forward_transform_int(h, irs, {.kernel = LiftingKernel::reference});
            ASSERT_EQ(ifast, iref) << channels << " channels, forward int";
            inverse_transform(h, fs);
            inverse_transform(h, rs, {.kernel = LiftingKernel::reference});
            ASSERT_EQ(fast, ref) << channels << " channels, inverse";
            inverse_transform_int(h, ifs);
            inverse_transform_int(h, irs, {.kernel = LiftingKernel::reference});
            ASSERT_EQ(ifast, iref) << channels << " channels, inverse int";
        }
    }
}

void fast_kernel_matches_on_threads(const Hierarchy& h) {
    std::mt19937_64 rng(7);
    std::vector<float> input(h.num_samples(4));
    for (float& v : input) v = static_cast<float>(uniform(rng) * 255);
    std::vector<float> ref = input;
    const std::span<float> rs[] = {ref};
    forward_transform(h, rs, {.kernel = LiftingKernel::reference});
    for (int threads : {1, 3}) {
        set_thread_count(threads);
        std::vector<float> x = input;
        const std::span<float> xs[] = {x};
        forward_transform(h, xs);
        EXPECT_EQ(x, ref) << threads << " threads, forward";
        inverse_transform(h, xs);
        std::vector<float> back = ref;
        const std::span<float> bs[] = {back};
        inverse_transform(h, bs, {.kernel = LiftingKernel::reference});
        EXPECT_EQ(x, back) << threads << " threads, inverse";
    }
}

// Patches and skeleton points shared among threads (parallel.h) change nothing: on meshes of
// thousands of patches (a grid, and a Voronoi mesh with irregular vertices), the fast kernel on 1
// and on 3 threads equals the reference kernel to the bit, both ways.
TEST(Lifting, fast_kernel_is_bit_identical_on_any_thread_count) {
    for (const Mesh& mesh :
         {grid_mesh(400, 300, 40, 30), voronoi_mesh(400, 300, {.sites = 600, .seed = 3})}) {
        fast_kernel_matches_on_threads(build_hierarchy(mesh, {.levels = 4}));
    }
    set_thread_count(0);
}

TEST(Lifting, plane_size_mismatch_is_an_error) {
    const Hierarchy h = build_hierarchy(grid_mesh(4, 4, 1, 1), {.levels = 2});
    std::vector<float> wrong(h.num_samples(2) - 1);
    std::span<float> planes[] = {wrong};
    EXPECT_THROW(forward_transform(h, planes), Error);
    std::vector<float> right(h.num_samples(2));
    std::span<float> ok[] = {right};
    EXPECT_THROW(forward_transform(h, ok, {.steps = 3}), Error);
}

}  // namespace
}  // namespace tesswave
