#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "core/math/error.h"
#include "core/math/grid_mesh.h"
#include "core/math/parametrization.h"
#include "core/math/sampling.h"
#include "morph/warp.h"
#include "samples/sample_images.h"
#include "test_meshes.h"

namespace tesswave::morph {
namespace {

// A plan over a deformed grid and the T1 quads' maps into two other deformations of it, some of
// whose pixels lie past the images' borders (the taps clamp there).
struct Scene {
    Mesh mesh = testing::deformed_grid(97, 61, 4, 3, 0.22, 3);
    Hierarchy h = build_hierarchy(mesh, {.levels = 3});
    RenderPlan plan = plan_render(h, mesh.vertices, 97, 61, 97, 61);
    std::vector<QuadMap> maps_a = maps(1.05, -2.0), maps_b = maps(0.93, 3.5);
    Image ra = samples::scene_image(97, 61, 1), rb = samples::scene_image(97, 61, 2);

    std::vector<QuadMap> maps(double scale, double shift) const {
        std::vector<Quad> quads = t1_quads(h, mesh.vertices);
        for (Quad& q : quads) {
            for (Vec2& p : q) p = {scale * p.x + shift, scale * p.y - shift};
        }
        return quad_maps(quads);
    }
};

std::vector<std::vector<float>> sample_planes(const Hierarchy& h, int count) {
    std::vector<std::vector<float>> out(count, std::vector<float>(h.num_samples(3)));
    for (int c = 0; c < count; ++c) {
        for (size_t k = 0; k < out[c].size(); ++k) out[c][k] = std::sin(0.37f * k + c);
    }
    return out;
}

// compose is, to the bit, the rendered colour plus the residuals fetched a pixel at a time at the
// maps' positions: one residual or two, fixed weights or per-sample ones, 3 or 4 channels.
TEST(MorphWarp, compose_gives_the_per_pixel_formula_to_the_bit) {
    const Scene s;
    for (int channels : {3, 4}) {
        for (const auto& mode : {std::pair{false, false}, {true, false}, {true, true}}) {
            const bool both = mode.first, weighted = mode.second;  // lambdas capture these
            SCOPED_TRACE(::testing::Message()
                         << channels << " channels, both " << both << ", weighted " << weighted);
            const auto x = sample_planes(s.h, channels + (weighted ? 2 : 0));
            const std::vector<std::span<const float>> planes(x.begin(), x.end());
            Image ra = s.ra, rb = s.rb;
            if (channels == 4) ra.planes.push_back(ra.planes[0]), rb.planes.push_back(rb.planes[1]);
            const ResidualWarp warp{s.maps_a, s.maps_b, ra, rb, 0.75f, 0.375f, both, weighted};
            Image got = make_image(97, 61, channels, SampleFormat::f32);
            compose(s.plan, planes, warp, got);
            Image want = make_image(97, 61, channels, SampleFormat::f32);
            render_each<0>(s.plan, planes, [&](int32_t px, const float* v, PlanPlace at) {
                const Tap ta = bilinear_tap(97, 61, 1.0, s.maps_a[at.quad].at(at.u, at.v));
                const Tap tb = bilinear_tap(97, 61, 1.0, s.maps_b[at.quad].at(at.u, at.v));
                const float wa = weighted ? v[channels] : 0.75f;
                const float wb = weighted ? v[channels + 1] : 0.375f;
                for (int c = 0; c < channels; ++c) {
                    const float a = bilinear_at(ta, ra.planes[c].data());
                    want.planes[c][px] =
                        both ? v[c] + (wa * a + wb * bilinear_at(tb, rb.planes[c].data()))
                             : v[c] + 0.75f * a;
                }
            });
            for (int c = 0; c < channels; ++c) {
                EXPECT_EQ(0, std::memcmp(got.planes[c].data(), want.planes[c].data(),
                                         want.planes[c].size() * sizeof(float)))
                    << "channel " << c;
            }
        }
    }
}

TEST(MorphWarp, warped_through_fetches_each_pixel_at_its_place_to_the_bit) {
    const Scene s;
    const Image got = warped_through(s.plan, s.maps_b, s.rb);
    Image want = make_image(97, 61, 2, SampleFormat::f32);
    render_each<0>(s.plan, {}, [&](int32_t px, const float*, PlanPlace at) {
        const Tap t = bilinear_tap(97, 61, 1.0, s.maps_b[at.quad].at(at.u, at.v));
        for (int c = 0; c < 2; ++c) want.planes[c][px] = bilinear_at(t, s.rb.planes[c].data());
    });
    for (int c = 0; c < 2; ++c) {
        EXPECT_EQ(0, std::memcmp(got.planes[c].data(), want.planes[c].data(),
                                 want.planes[c].size() * sizeof(float)));
    }
}

TEST(MorphWarp, compose_refuses_planes_that_do_not_match) {
    const Scene s;
    const auto x = sample_planes(s.h, 4);
    const std::vector<std::span<const float>> planes(x.begin(), x.end());
    Image out = make_image(97, 61, 3, SampleFormat::f32);
    const ResidualWarp weighted{s.maps_a, s.maps_b, s.ra, s.rb, 0, 0, true, true};
    EXPECT_THROW(compose(s.plan, planes, weighted, out), Error);  // 4 planes, 5 needed
}

}  // namespace
}  // namespace tesswave::morph
