#include "core/eval/analysis.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/math/lifting.h"
#include "core/math/metrics.h"
#include "core/math/render.h"
#include "core/math/sampling.h"
#include "samples/sample_images.h"
#include "samples/sample_meshes.h"
#include "test_meshes.h"

namespace tesswave {
namespace {

// Smooth shading only: a few low-frequency waves per channel.
Image smooth_image(int w, int h) {
    Image image = make_image(w, h, 3);
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            const double u = x / double(w), v = y / double(h);
            image.at(0, x, y) = static_cast<float>(0.5 + 0.3 * std::sin(5 * u + 2 * v));
            image.at(1, x, y) = static_cast<float>(0.4 + 0.25 * std::cos(3 * u - 4 * v));
            image.at(2, x, y) = static_cast<float>(0.5 + 0.2 * std::sin(7 * u * v + 1));
        }
    }
    return image;
}

TEST(Analysis, resampling_a_smooth_image_at_density_3_5_is_nearly_lossless) {
    const Image image = smooth_image(249, 251);
    const Mesh mesh = samples::paper_t0(249, 251);
    const AnalysisResult r = analyze_image(image, mesh, {.levels = 7, .keep = {10}});
    ASSERT_EQ(r.rows[0].method, "resample point");
    EXPECT_NEAR(r.samples_per_pixel, 3.49, 0.01);
    EXPECT_GT(r.rows[0].psnr, 40.0);
    EXPECT_GT(r.rows[0].ssim, 0.99);
    // A smooth image at 3.5 samples a pixel is already within the projection's tolerance: it
    // keeps the point samples.
    ASSERT_EQ(r.rows[1].method, "resample fit");
    EXPECT_GE(r.rows[1].psnr, r.rows[0].psnr - 0.01);
}

// Keeping every coefficient reconstructs the samples (to float rounding), so the render equals
// the resample.
TEST(Analysis, full_reconstruction_equals_the_resample) {
    const Image image = samples::scene_image(120, 90);
    const Mesh mesh = samples::paper_t0(120, 90);
    const Hierarchy h = build_hierarchy(mesh, {.levels = 5});
    auto samples = sample_image(image, h, mesh.vertices);
    auto coefficients = samples;
    std::vector<std::span<float>> spans(coefficients.begin(), coefficients.end());
    forward_transform(h, spans);
    inverse_transform(h, spans);
    const RenderPlan plan = plan_render(h, mesh.vertices, 120, 90, 120, 90);
    const std::vector<std::span<const float>> sa(samples.begin(), samples.end());
    const std::vector<std::span<const float>> sb(coefficients.begin(), coefficients.end());
    const Image a = render(plan, sa);
    const Image b = render(plan, sb);
    for (int c = 0; c < 3; ++c) {
        for (size_t i = 0; i < a.planes[c].size(); ++i) {
            ASSERT_NEAR(a.planes[c][i], b.planes[c][i], 1e-6);
        }
    }
    // Rows 0 and 1 are the point and fit resamples; the analysis goes on with its sampling.
    for (Sampling sampling : {Sampling::point, Sampling::fit}) {
        const AnalysisResult r =
            analyze_image(image, mesh, {.levels = 5, .keep = {100}, .sampling = sampling});
        const AnalysisRow& resample = r.rows[sampling == Sampling::point ? 0 : 1];
        EXPECT_EQ(r.rows[2].method, "mesh paper");
        EXPECT_EQ(r.rows[2].kept, r.rows[2].total);
        EXPECT_NEAR(r.rows[2].psnr, resample.psnr, 0.01);
    }
}

// Fewer coefficients, lower quality; the L2 rule is at least as good as the paper's at equal
// count on a natural-looking image; the fixed-grid rows use the same percentages.
TEST(Analysis, rows_are_ordered_and_complete) {
    const Image image = samples::scene_image(160, 120);
    const AnalysisResult r =
        analyze_image(image, samples::paper_t0(160, 120), {.levels = 6, .keep = {10, 1}});
    ASSERT_EQ(r.rows.size(), 2u + 4 + 4 + 4);
    EXPECT_GT(r.rows[2].psnr, r.rows[4].psnr);  // mesh paper 10 % > 1 %
    EXPECT_GE(r.rows[5].psnr, r.rows[4].psnr);  // mesh l2 1 % >= paper 1 %
    EXPECT_EQ(r.rows[6].method, "grid 5/3");
    EXPECT_EQ(r.rows[6].total, 160 * 120 - 20 * 15);  // all but the 3-level LL band (20x15)
    EXPECT_EQ(r.rows[8].method, "grid 5/3 =n");
    EXPECT_EQ(r.rows[8].kept, r.rows[2].kept);  // as many coefficients as the mesh kept
    EXPECT_EQ(r.mesh_images.size(), 2u);
    EXPECT_EQ(r.grid97_images.size(), 2u);
}

TEST(Analysis, rejects_a_mesh_of_another_size_and_bad_percentages) {
    const Image image = samples::scene_image(64, 48);
    EXPECT_NE(testing::error_of([&] {
                  analyze_image(image, samples::paper_t0(60, 48), {});
              }).find("does not match"),
              std::string::npos);
    EXPECT_THROW(analyze_image(image, samples::paper_t0(64, 48), {.levels = 3, .keep = {0}}),
                 Error);
    EXPECT_THROW(analyze_image(image, samples::paper_t0(64, 48), {.levels = 3, .keep = {101}}),
                 Error);
}

}  // namespace
}  // namespace tesswave
