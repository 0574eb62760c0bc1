#include "core/math/project.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include "core/math/error.h"
#include "core/math/grid_mesh.h"
#include "core/math/lifting.h"
#include "core/math/metrics.h"
#include "core/math/parallel.h"
#include "core/math/project_grids.h"
#include "core/math/render.h"
#include "core/math/sampling.h"
#include "core/math/voronoi.h"
#include "samples/sample_images.h"

namespace tesswave {
namespace {

using Planes = std::vector<std::vector<float>>;

// The image rendered back from samples on the mesh, in float.
Image rendered(const Hierarchy& h, const Mesh& mesh, const Planes& samples, int w, int height) {
    const RenderPlan plan = plan_render(h, mesh.vertices, w, height, w, height);
    const std::vector<std::span<const float>> in(samples.begin(), samples.end());
    return render(plan, in, SampleFormat::f32);
}

double round_trip(const Image& image, const Hierarchy& h, const Mesh& mesh, const Planes& s) {
    return psnr(image, rendered(h, mesh, s, image.width, image.height), {.bit_depth = 16}).all;
}

bool all_finite(const Planes& planes) {
    for (const auto& p : planes) {
        for (float v : p) {
            if (!std::isfinite(v)) return false;
        }
    }
    return true;
}

// A grid whose level-J samples fall between pixel centres, at about one sample a pixel: point
// sampling blurs twice (sampling, then rendering); the projection undoes most of it.
TEST(Project, a_grid_between_the_pixels_gains_over_point_sampling) {
    const Image image = samples::scene_image(160, 120);
    const Mesh mesh = grid_mesh(160, 120, 10, 8);  // J = 4: 16-pixel cells, ~1 sample a pixel
    const Hierarchy h = build_hierarchy(mesh, {.levels = 4});
    const Planes point = sample_image(image, h, mesh.vertices);
    const Projection fit = project_image(image, h, mesh.vertices);
    const double p = round_trip(image, h, mesh, point), f = round_trip(image, h, mesh, fit.planes);
    EXPECT_GT(f, p + 8) << "point " << p << " dB, fit " << f << " dB";
    EXPECT_GT(fit.iterations, 0);
    EXPECT_LE(fit.iterations, ProjectOptions{}.max_iterations);
    EXPECT_TRUE(all_finite(fit.planes));
}

// At about a sample a pixel, between the pixel centres, rendering blurs like [1 2 1] / 4 along
// each axis; the line preconditioner inverts that blur, where Jacobi leaves the conjugate
// gradients to find the sharp detail a few modes an iteration. With four iterations it gets much
// closer to the converged samples, and it reaches the tolerance in fewer; both converge to the
// same samples. Quads denser than 1.4 cells a pixel keep Jacobi: at 2 samples a pixel the two
// take the same steps.
TEST(Project, the_line_preconditioner_converges_in_fewer_iterations) {
    const Image image = samples::scene_image(320, 240);
    const Mesh mesh = grid_mesh(320, 240, 10, 8);  // J = 5: 32x30-pixel cells, ~1 sample a pixel
    const Hierarchy h = build_hierarchy(mesh, {.levels = 5});
    auto solve = [&](Preconditioner pc, int iterations, double tolerance) {
        return project_image(
            image, h, mesh.vertices,
            {.max_iterations = iterations, .tolerance = tolerance, .preconditioner = pc});
    };
    const Projection lines4 = solve(Preconditioner::lines, 4, 0);
    const Projection jacobi4 = solve(Preconditioner::jacobi, 4, 0);
    const Projection lines = solve(Preconditioner::lines, 200, 1e-6);
    const Projection jacobi = solve(Preconditioner::jacobi, 200, 1e-6);
    const double l4 = round_trip(image, h, mesh, lines4.planes);
    const double j4 = round_trip(image, h, mesh, jacobi4.planes);
    const double l = round_trip(image, h, mesh, lines.planes);
    const double j = round_trip(image, h, mesh, jacobi.planes);
    EXPECT_GT(l4, j4 + 3) << "4 iterations: lines " << l4 << " dB, jacobi " << j4 << " dB";
    EXPECT_LT(2 * lines.iterations, jacobi.iterations)
        << "lines " << lines.iterations << ", jacobi " << jacobi.iterations;
    EXPECT_NEAR(l, j, 0.05) << "converged: lines " << l << " dB, jacobi " << j << " dB";

    const DefaultGrid dense = default_grid(320, 240, 2.0);
    const Mesh grid = grid_mesh(320, 240, dense.cols, dense.rows);
    const Hierarchy hd = build_hierarchy(grid, {.levels = dense.levels});
    const Projection dl = project_image(image, hd, grid.vertices, {});
    const Projection dj =
        project_image(image, hd, grid.vertices, {.preconditioner = Preconditioner::jacobi});
    EXPECT_NEAR(dl.iterations, dj.iterations, 1);
    EXPECT_NEAR(round_trip(image, hd, grid, dl.planes), round_trip(image, hd, grid, dj.planes),
                0.05);
}

// The quads and channels are shared among the cores; the samples are the same to the bit on any
// number of threads (sums are made in a fixed order).
TEST(Project, samples_are_identical_whatever_the_thread_count) {
    const Image image = samples::scene_image(160, 120);
    const Mesh mesh = voronoi_mesh(160, 120, {.sites = 30, .seed = 4});
    const Hierarchy h = build_hierarchy(mesh, {.levels = 3});
    set_thread_count(1);
    const Projection one = project_image(image, h, mesh.vertices, {.smoothness = 0.01});
    for (int threads : {2, 3}) {
        set_thread_count(threads);
        const Projection many = project_image(image, h, mesh.vertices, {.smoothness = 0.01});
        EXPECT_EQ(many.planes, one.planes) << threads << " threads";
        EXPECT_EQ(many.iterations, one.iterations) << threads << " threads";
    }
    set_thread_count(0);
    EXPECT_GT(one.iterations, 1);
}

// The same on a Voronoi mesh (J for about 2 samples a pixel): not a grid trick.
TEST(Project, a_voronoi_mesh_gains_too) {
    const Image image = samples::scene_image(160, 120, 3);
    const Mesh mesh = voronoi_mesh(160, 120, {.sites = 30, .seed = 4});
    const int J = level_for_density(mesh, 160 * 120, 2.0);
    const Hierarchy h = build_hierarchy(mesh, {.levels = J});
    const double p = round_trip(image, h, mesh, sample_image(image, h, mesh.vertices));
    const double f = round_trip(image, h, mesh, project_image(image, h, mesh.vertices).planes);
    EXPECT_GT(f, p + 5) << "point " << p << " dB, fit " << f << " dB";
}

// Smoothness trades the round trip for cheaper finest bands: their energy falls.
TEST(Project, smoothness_shrinks_the_finest_band) {
    const Image image = samples::scene_image(160, 120);
    const Mesh mesh = grid_mesh(160, 120, 10, 8);
    const Hierarchy h = build_hierarchy(mesh, {.levels = 4});
    auto finest_energy = [&](double beta) {
        Planes x = project_image(image, h, mesh.vertices, {.smoothness = beta}).planes;
        std::vector<std::span<float>> s(x.begin(), x.end());
        forward_transform(h, s);
        double e = 0;
        for (const auto& plane : x) {
            for (int32_t i = h.num_samples(3); i < h.num_samples(4); ++i) e += plane[i] * plane[i];
        }
        return e;
    };
    EXPECT_LT(finest_energy(0.03), 0.7 * finest_energy(0.0));
}

// Several smoothness values from one assembly: the first is project_image's to the bit; each
// later one, started from the one before, solves its own system (residual within the tolerance)
// and renders as project_image's does.
TEST(Project, each_smoothness_from_one_assembly_matches_a_call_per_value) {
    const Image image = samples::scene_image(160, 120, 3);
    const Mesh mesh = grid_mesh(160, 120, 10, 8);
    const Hierarchy h = build_hierarchy(mesh, {.levels = 4});
    const std::vector<double> betas = {0.03, 0.01, 0.0};
    const ProjectOptions options{.max_iterations = 200};
    std::vector<Projection> each;
    project_image_each(image, h, mesh.vertices, betas, options, [&](size_t k, const Projection& p) {
        EXPECT_EQ(k, each.size());
        each.push_back(p);
    });
    ASSERT_EQ(each.size(), betas.size());
    int each_total = 0, alone_total = 0;
    for (size_t k = 0; k < betas.size(); ++k) {
        ProjectOptions one = options;
        one.smoothness = betas[k];
        const Projection alone = project_image(image, h, mesh.vertices, one);
        if (k == 0) {
            EXPECT_EQ(each[k].planes, alone.planes);
        }
        EXPECT_LE(each[k].residual, options.tolerance) << "smoothness " << betas[k];
        EXPECT_LT(each[k].iterations, options.max_iterations);
        const double a = round_trip(image, h, mesh, alone.planes);
        const double e = round_trip(image, h, mesh, each[k].planes);
        EXPECT_NEAR(e, a, 0.05) << "smoothness " << betas[k];
        each_total += each[k].iterations;
        alone_total += alone.iterations;
    }
    // Later solves start close: fewer iterations in all than solves from the point samples.
    EXPECT_LT(each_total, alone_total);
}

// A render plan the caller keeps gives the same samples to the bit as the one made inside; one
// of another size is refused.
TEST(Project, a_given_render_plan_gives_the_same_samples) {
    const Image image = samples::scene_image(160, 120, 3);
    const Mesh mesh = grid_mesh(160, 120, 10, 8);
    const Hierarchy h = build_hierarchy(mesh, {.levels = 4, .finest_topology = false});
    const RenderPlan plan = plan_render(h, mesh.vertices, 160, 120, 160, 120);
    const Projection own = project_image(image, h, mesh.vertices, {.smoothness = 0.01});
    const Projection given =
        project_image(image, h, mesh.vertices, {.smoothness = 0.01, .plan = &plan});
    EXPECT_EQ(given.planes, own.planes);
    EXPECT_EQ(given.iterations, own.iterations);
    const RenderPlan half = plan_render(h, mesh.vertices, 160, 120, 80, 60);
    EXPECT_THROW(project_image(image, h, mesh.vertices, {.plan = &half}), Error);
}

// Alpha is a channel like the others; each channel is fitted on its own, whatever the others.
TEST(Project, any_number_of_channels) {
    const Mesh mesh = grid_mesh(64, 48, 4, 3);
    const Hierarchy h = build_hierarchy(mesh, {.levels = 4});
    const Image scene = samples::scene_image(64, 48);
    std::vector<float> first;
    for (int channels : {1, 2, 4}) {
        Image image = make_image(64, 48, channels, SampleFormat::f32);
        for (int c = 0; c < channels; ++c) image.planes[c] = scene.planes[c % 3];
        const Projection fit = project_image(image, h, mesh.vertices);
        ASSERT_EQ(fit.planes.size(), static_cast<size_t>(channels));
        if (first.empty()) first = fit.planes[0];
        EXPECT_EQ(fit.planes[0], first) << channels << " channels";
        if (channels == 4) {
            EXPECT_EQ(fit.planes[3], fit.planes[0]);  // alpha = red here
        }
    }
}

// Non-finite pixels are left out of the fit: no NaN anywhere, and the rest still fits.
TEST(Project, non_finite_pixels_are_ignored) {
    Image image = samples::scene_image(96, 64);
    const Mesh mesh = grid_mesh(96, 64, 6, 4);
    const Hierarchy h = build_hierarchy(mesh, {.levels = 4});
    const double clean = round_trip(image, h, mesh, project_image(image, h, mesh.vertices).planes);
    image.planes[1][100] = std::numeric_limits<float>::quiet_NaN();
    image.planes[0][2000] = std::numeric_limits<float>::infinity();
    const Projection fit = project_image(image, h, mesh.vertices);
    EXPECT_TRUE(all_finite(fit.planes));
    Image reference = samples::scene_image(96, 64);
    EXPECT_GT(round_trip(reference, h, mesh, fit.planes), clean - 3);
    // All non-finite: the anchor (zeros where the point samples were not finite).
    Image empty = make_image(8, 8, 1, SampleFormat::f32);
    for (float& v : empty.planes[0]) v = std::numeric_limits<float>::quiet_NaN();
    const Mesh small = grid_mesh(8, 8, 1, 1);
    const Hierarchy hs = build_hierarchy(small, {.levels = 2});
    EXPECT_TRUE(all_finite(project_image(empty, hs, small.vertices).planes));
}

// Faces far smaller than pixels (underdetermined: many samples, few pixels) and a mesh far
// coarser than the pixels (overdetermined): bounded iterations, finite values, and a render
// never worse than point sampling.
TEST(Project, tiny_and_huge_cells_are_never_worse_than_point_sampling) {
    const Image image = samples::scene_image(48, 36);
    for (const auto& [cols, rows, levels] :
         {std::tuple{3, 2, 6}, std::tuple{1, 1, 2}, std::tuple{2, 1, 1}}) {
        const Mesh mesh = grid_mesh(48, 36, cols, rows);
        const Hierarchy h = build_hierarchy(mesh, {.levels = levels});
        const Projection fit = project_image(image, h, mesh.vertices, {.max_iterations = 50});
        EXPECT_LE(fit.iterations, 50);
        EXPECT_TRUE(all_finite(fit.planes));
        const double p = round_trip(image, h, mesh, sample_image(image, h, mesh.vertices));
        EXPECT_GE(round_trip(image, h, mesh, fit.planes), p - 0.01)
            << cols << "x" << rows << " J=" << levels;
    }
}

TEST(Project, bad_options_throw) {
    const Image image = samples::scene_image(32, 24);
    const Mesh mesh = grid_mesh(32, 24, 2, 2);
    const Hierarchy h = build_hierarchy(mesh, {.levels = 3});
    EXPECT_THROW(project_image(image, h, mesh.vertices, {.level = 4}), Error);
    EXPECT_THROW(project_image(image, h, mesh.vertices, {.anchor_weight = 0}), Error);
    EXPECT_THROW(project_image(image, h, mesh.vertices, {.smoothness = -1}), Error);
    EXPECT_THROW(project_image(image, h, mesh.vertices, {.max_iterations = 1001}), Error);
    EXPECT_THROW(project_image(image, h, mesh.vertices,
                               {.tolerance = std::numeric_limits<double>::quiet_NaN()}),
                 Error);
    const std::vector<float> short_plane(10);
    const std::span<const float> anchor[] = {short_plane, short_plane, short_plane};
    EXPECT_THROW(project_image(image, h, mesh.vertices, {.anchor = anchor}), Error);
    EXPECT_THROW(sampling_from_name("exact"), Error);
    EXPECT_EQ(sampling_from_name(sampling_name(Sampling::fit)), Sampling::fit);
}

}  // namespace
}  // namespace tesswave

namespace tesswave {
namespace {

// Values spread over many binary orders of magnitude, so that any change in the order of the
// additions (or a fused multiply-add) changes the rounded results.
std::vector<float> spread_values(size_t n, std::mt19937& rng) {
    std::uniform_real_distribution<float> mantissa(-1.0f, 1.0f);
    std::uniform_int_distribution<int> exponent(-12, 12);
    std::vector<float> v(n);
    for (float& x : v) x = std::ldexp(mantissa(rng), exponent(rng));
    return v;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

TEST(ProjectKernels, avx2_and_baseline_builds_give_the_same_bits) {
    const detail::VectorKernels* avx2 = detail::avx2_kernels();
    if (avx2 == nullptr) GTEST_SKIP() << "this machine has no AVX2: one build only";
    const detail::VectorKernels& base = detail::baseline_kernels();
    std::mt19937 rng(7);
    for (const int32_t n : {1, 3, 7, 8, 9, 15, 16, 17, 33, 64, 1089, 4097}) {
        SCOPED_TRACE(n);
        // The stencil product on a row of n nodes of a grid 33 wide, read with its neighbours.
        const int32_t side = 33, margin = side + 1;
        const int32_t offset[9] = {-side - 1, -side, -side + 1, -1, 0, 1, side - 1, side, side + 1};
        std::vector<std::vector<float>> entries(9);
        const float* st[9];
        for (int e = 0; e < 9; ++e) st[e] = (entries[e] = spread_values(n, rng)).data();
        const std::vector<float> g = spread_values(n + 2 * margin, rng);
        std::vector<float> o_base(n), o_avx2(n);
        base.stencil_row(st, g.data() + margin, offset, n, o_base.data());
        avx2->stencil_row(st, g.data() + margin, offset, n, o_avx2.data());
        EXPECT_TRUE(same_bits(o_base, o_avx2));

        const std::vector<float> a = spread_values(n, rng), b = spread_values(n, rng);
        std::vector<float> owner(n);
        for (int32_t k = 0; k < n; ++k) owner[k] = (k % 5 == 3) ? 0.0f : 1.0f;
        EXPECT_EQ(std::bit_cast<uint64_t>(base.dot(a.data(), b.data(), owner.data(), n)),
                  std::bit_cast<uint64_t>(avx2->dot(a.data(), b.data(), owner.data(), n)));
        std::vector<uint8_t> shared(n);
        for (int32_t k = 0; k < n; ++k) shared[k] = owner[k] == 0;
        const double own = base.own_dot(a.data(), b.data(), shared.data(), n);
        EXPECT_EQ(std::bit_cast<uint64_t>(own),
                  std::bit_cast<uint64_t>(avx2->own_dot(a.data(), b.data(), shared.data(), n)));
        EXPECT_EQ(own, base.dot(a.data(), b.data(), owner.data(), n));

        const std::vector<float> p = spread_values(n, rng), ap = spread_values(n, rng);
        const std::vector<float> inverse = spread_values(n, rng);
        std::vector<float> x_base = spread_values(n, rng), r_base = spread_values(n, rng);
        std::vector<float> x_avx2 = x_base, r_avx2 = r_base;
        const auto [rz_base, rr_base] =
            base.step_channel(0.37f, x_base.data(), r_base.data(), p.data(), ap.data(),
                              inverse.data(), owner.data(), n);
        const auto [rz_avx2, rr_avx2] =
            avx2->step_channel(0.37f, x_avx2.data(), r_avx2.data(), p.data(), ap.data(),
                               inverse.data(), owner.data(), n);
        EXPECT_TRUE(same_bits(x_base, x_avx2));
        EXPECT_TRUE(same_bits(r_base, r_avx2));
        EXPECT_EQ(std::bit_cast<uint64_t>(rz_base), std::bit_cast<uint64_t>(rz_avx2));
        EXPECT_EQ(std::bit_cast<uint64_t>(rr_base), std::bit_cast<uint64_t>(rr_avx2));

        std::vector<float> p_base = p, p_avx2 = p;
        base.next_direction(0.61f, r_base.data(), inverse.data(), p_base.data(), n);
        avx2->next_direction(0.61f, r_base.data(), inverse.data(), p_avx2.data(), n);
        EXPECT_TRUE(same_bits(p_base, p_avx2));

        std::vector<float> x2_base = x_base, r2_base = r_base, x2_avx2 = x_base, r2_avx2 = r_base;
        const double rr2_base = base.step_residual(0.29f, x2_base.data(), r2_base.data(), p.data(),
                                                   ap.data(), owner.data(), n);
        const double rr2_avx2 = avx2->step_residual(0.29f, x2_avx2.data(), r2_avx2.data(), p.data(),
                                                    ap.data(), owner.data(), n);
        EXPECT_TRUE(same_bits(x2_base, x2_avx2));
        EXPECT_TRUE(same_bits(r2_base, r2_avx2));
        EXPECT_EQ(std::bit_cast<uint64_t>(rr2_base), std::bit_cast<uint64_t>(rr2_avx2));
        base.next_direction_from(0.53f, inverse.data(), p_base.data(), n);
        avx2->next_direction_from(0.53f, inverse.data(), p_avx2.data(), n);
        EXPECT_TRUE(same_bits(p_base, p_avx2));
    }
}

}  // namespace
}  // namespace tesswave
