#include "core/math/render.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "core/math/grid_mesh.h"
#include "core/math/parallel.h"
#include "core/math/parametrization.h"
#include "core/math/sampling.h"
#include "core/math/voronoi.h"
#include "samples/sample_images.h"
#include "samples/sample_meshes.h"
#include "test_meshes.h"

namespace tesswave {
namespace {

struct Case {
    const char* name;
    Mesh mesh;
};

std::vector<Case> cases() {
    Mesh crossing = samples::paper_t0(97, 61);
    crossing.features = {{5, 6}, {6, 7}, {7, 8}, {8, 9}};
    return {{"paper", samples::paper_t0(97, 61)},
            {"deformed grid", testing::deformed_grid(97, 61, 4, 3, 0.22, 3)},
            {"voronoi", voronoi_mesh(97, 61, {.sites = 17, .seed = 4})},
            {"features", crossing}};
}

// Every pixel belongs to exactly one T1 quad, at the mesh's own size and at other sizes.
TEST(Render, every_pixel_is_written_exactly_once) {
    for (auto& [name, mesh] : cases()) {
        SCOPED_TRACE(name);
        testing::expect_valid(mesh);
        const Hierarchy h = build_hierarchy(mesh, {.levels = 3});
        for (auto [w, hgt] : {std::pair{97, 61}, {203, 117}, {31, 50}}) {
            const RenderPlan plan = plan_render(h, mesh.vertices, 97, 61, w, hgt);
            std::vector<int> writes(static_cast<size_t>(w) * hgt, 0);
            for (size_t run = 0; run < plan.run_start.size(); ++run) {
                for (int32_t n = 0; n < plan.run_length[run]; ++n)
                    ++writes[plan.run_start[run] + n];
            }
            for (size_t px = 0; px < writes.size(); ++px) {
                ASSERT_EQ(writes[px], 1) << w << "x" << hgt << " pixel " << px;
            }
        }
    }
}

// Each pixel's plan entry is its place in its quad by inverse_bilinear, one pixel at a time: the
// cell (r m + c over (m+1)^2 nodes) and the fractions along c and r, rounded to 2^-16 (the four-
// pixel kernels must give these bits on every run length, tails included).
TEST(Render, plan_entries_are_each_pixels_inverse_bilinear_place) {
    for (auto& [name, mesh] : cases()) {
        SCOPED_TRACE(name);
        const Hierarchy h = build_hierarchy(mesh, {.levels = 3});
        const std::vector<Quad> quads = t1_quads(h, mesh.vertices);
        for (auto [w, hgt] : {std::pair{97, 61}, {203, 117}}) {
            const RenderPlan plan = plan_render(h, mesh.vertices, 97, 61, w, hgt);
            const int32_t m = plan.cells;
            const double sx = w / 97.0, sy = hgt / 61.0;
            size_t entry = 0;
            for (size_t q = 0; q + 1 < plan.quad_runs.size(); ++q) {
                Quad scaled = quads[q];
                for (Vec2& c : scaled) c = {c.x * sx, c.y * sy};
                for (int32_t run = plan.quad_runs[q]; run < plan.quad_runs[q + 1]; ++run) {
                    for (int32_t n = 0; n < plan.run_length[run]; ++n, ++entry) {
                        const int32_t px = plan.run_start[run] + n;
                        const UV uv = inverse_bilinear(scaled, {px % w + 0.5, px / w + 0.5});
                        const double s = uv.u * m, r = uv.v * m;
                        const int32_t c0 = std::min(static_cast<int32_t>(s), m - 1);
                        const int32_t r0 = std::min(static_cast<int32_t>(r), m - 1);
                        const auto fixed = [](double f) {
                            return std::min(65535L, std::lround(f * 65536));
                        };
                        ASSERT_EQ(plan.cell[entry], r0 * (m + 1) + c0) << "pixel " << px;
                        ASSERT_EQ(plan.st[entry][0], fixed(s - c0)) << "pixel " << px;
                        ASSERT_EQ(plan.st[entry][1], fixed(r - r0)) << "pixel " << px;
                    }
                }
            }
            ASSERT_EQ(entry, plan.cell.size());
        }
    }
}

// A constant renders to exactly that constant; a function linear in x, y renders to that
// function at the pixel centres (the level-J grid is the bilinear map of each quad).
TEST(Render, constant_and_linear_functions_render_exactly) {
    for (auto& [name, mesh] : cases()) {
        SCOPED_TRACE(name);
        const Hierarchy h = build_hierarchy(mesh, {.levels = 4});
        const auto p = refine_positions(h, mesh.vertices, 4);
        std::vector<float> constant(p.size(), 0.3125f), linear(p.size());
        auto f = [](double x, double y) { return 0.1 + 0.004 * x - 0.003 * y; };
        for (size_t i = 0; i < p.size(); ++i) linear[i] = static_cast<float>(f(p[i].x, p[i].y));
        const RenderPlan plan = plan_render(h, mesh.vertices, 97, 61, 97, 61);
        std::span<const float> planes[] = {constant, linear};
        const Image out = render(plan, planes);
        for (int y = 0; y < 61; ++y) {
            for (int x = 0; x < 97; ++x) {
                ASSERT_EQ(out.at(0, x, y), 0.3125f) << x << "," << y;
                ASSERT_NEAR(out.at(1, x, y), f(x + 0.5, y + 0.5), 2e-6) << x << "," << y;
            }
        }
    }
}

// Sampling a linear image and rendering it back gives the image: sample-then-render is exact for
// linear content. Within about a cell of the border the samples read clamped pixels (a pixel's
// value sits at its centre; nothing is extrapolated past it), so that margin is left out.
TEST(Render, sampling_then_rendering_a_linear_image_is_exact) {
    const Mesh mesh = samples::paper_t0(97, 61);
    Image ramp = make_image(97, 61, 1, SampleFormat::f32);
    for (int y = 0; y < 61; ++y) {
        for (int x = 0; x < 97; ++x) ramp.at(0, x, y) = 0.2f + 0.005f * x + 0.002f * y;
    }
    const Hierarchy h = build_hierarchy(mesh, {.levels = 5});
    const auto planes = sample_image(ramp, h, mesh.vertices, {.prefilter = false});
    const RenderPlan plan = plan_render(h, mesh.vertices, 97, 61, 97, 61);
    std::span<const float> spans[] = {planes[0]};
    const Image out = render(plan, spans);
    for (int y = 3; y < 61 - 3; ++y) {
        for (int x = 3; x < 97 - 3; ++x) ASSERT_NEAR(out.at(0, x, y), ramp.at(0, x, y), 1e-5);
    }
}

// render_each (render_into is made of it) hands every pixel, once, the values render() writes
// there, to the bit.
TEST(Render, render_each_gives_what_render_writes) {
    for (const Case& c : cases()) {
        const Hierarchy h = build_hierarchy(c.mesh, {.levels = 3});
        const RenderPlan plan = plan_render(h, c.mesh.vertices, 97, 61, 131, 77);
        std::vector<float> x(h.num_samples(3)), y(x.size());
        for (size_t k = 0; k < x.size(); ++k) {
            x[k] = std::sin(0.37f * k) * std::ldexp(1.0f, k % 13 - 6);
            y[k] = std::cos(0.11f * k);
        }
        const std::span<const float> planes[] = {x, y};
        const Image rendered = render(plan, planes, SampleFormat::f32);
        std::vector<float> got_x(131 * 77, NAN), got_y = got_x;
        std::vector<int> calls(131 * 77, 0);
        set_thread_count(1);  // `calls` is counted without atomics
        render_each<2>(plan, planes, [&](int32_t px, const float* v) {
            got_x[px] = v[0], got_y[px] = v[1];
            ++calls[px];
        });
        set_thread_count(0);
        EXPECT_EQ(std::count(calls.begin(), calls.end(), 1), 131 * 77) << c.name;
        EXPECT_EQ(0, std::memcmp(got_x.data(), rendered.planes[0].data(), got_x.size() * 4))
            << c.name;
        EXPECT_EQ(0, std::memcmp(got_y.data(), rendered.planes[1].data(), got_y.size() * 4))
            << c.name;
    }
}

// Planes staged side by side (2 to 8, in SSE groups of four) or one after the other (1, or a count
// known at run time) render each plane as it renders alone, to the bit.
template <int C>
void expect_each_plane_as_alone(const RenderPlan& plan, const std::vector<std::vector<float>>& x,
                                const std::vector<Image>& alone) {
    SCOPED_TRACE(C);
    const std::vector<std::span<const float>> planes(x.begin(), x.begin() + (C > 0 ? C : 6));
    std::vector<std::vector<float>> got(planes.size(),
                                        std::vector<float>(alone[0].planes[0].size(), NAN));
    render_each<C>(plan, planes, [&](int32_t px, const float* v) {
        for (size_t c = 0; c < planes.size(); ++c) got[c][px] = v[c];
    });
    for (size_t c = 0; c < planes.size(); ++c) {
        EXPECT_EQ(0, std::memcmp(got[c].data(), alone[c].planes[0].data(), got[c].size() * 4))
            << "plane " << c;
    }
}

TEST(Render, every_channel_count_renders_each_plane_as_alone) {
    const Mesh mesh = testing::deformed_grid(97, 61, 4, 3, 0.22, 3);
    const Hierarchy h = build_hierarchy(mesh, {.levels = 3});
    const RenderPlan plan = plan_render(h, mesh.vertices, 97, 61, 131, 77);
    std::vector<std::vector<float>> x(8, std::vector<float>(h.num_samples(3)));
    std::vector<Image> alone;
    for (size_t c = 0; c < x.size(); ++c) {
        for (size_t k = 0; k < x[c].size(); ++k) {
            x[c][k] = std::sin(0.37f * k + c) * std::ldexp(1.0f, (k + c) % 13 - 6);
        }
        const std::span<const float> one[] = {x[c]};
        alone.push_back(render(plan, one, SampleFormat::f32));
    }
    expect_each_plane_as_alone<2>(plan, x, alone);
    expect_each_plane_as_alone<3>(plan, x, alone);
    expect_each_plane_as_alone<5>(plan, x, alone);
    expect_each_plane_as_alone<8>(plan, x, alone);
    expect_each_plane_as_alone<0>(plan, x, alone);
}

TEST(Render, rejects_bad_sizes_and_levels) {
    const Mesh mesh = samples::paper_t0(97, 61);
    const Hierarchy h = build_hierarchy(mesh, {.levels = 2});
    EXPECT_THROW(plan_render(h, mesh.vertices, 97, 61, 0, 10), Error);
    EXPECT_THROW(plan_render(h, mesh.vertices, 97, 61, 10, 10, {.level = 3}), Error);
    const RenderPlan plan = plan_render(h, mesh.vertices, 97, 61, 10, 10);
    std::vector<float> short_plane(h.num_samples(2) - 1);
    std::span<const float> planes[] = {short_plane};
    EXPECT_THROW(render(plan, planes), Error);
}

TEST(Sampling, density_picks_the_papers_level) {
    // The paper: 20 vertices, 14 faces, 249x251 pixels, ~3.5 samples a pixel -> level 7.
    EXPECT_EQ(level_for_density(samples::paper_t0(249, 251), 249 * 251, 3.5), 7);
    EXPECT_EQ(level_for_density(samples::paper_t0(249, 251), 249 * 251, 0.9), 6);
    EXPECT_THROW(level_for_density(samples::paper_t0(249, 251), 100, 0.0), Error);
}

// One rule for J: the grid the codecs build has the J that level_for_density gives for it.
TEST(Sampling, default_grid_agrees_with_level_for_density) {
    for (const auto& [w, h] : {std::pair{64, 48},
                               {176, 144},
                               {249, 251},
                               {640, 360},
                               {768, 512},
                               {1280, 720},
                               {37, 300}}) {
        for (const double density : {0.25, 0.5, 1.0, 2.0, 3.5, 8.0}) {
            const DefaultGrid g = default_grid(w, h, density);
            const Mesh mesh = grid_mesh(w, h, g.cols, g.rows);
            EXPECT_EQ(level_for_density(mesh, w * h, density), g.levels)
                << w << "x" << h << " at " << density;
            const double samples =
                (g.cols * std::ldexp(1.0, g.levels) + 1) * (g.rows * std::ldexp(1.0, g.levels) + 1);
            EXPECT_NEAR(std::log(samples / (density * w * h)), 0.0, 0.7) << w << "x" << h;
        }
    }
    EXPECT_EQ(default_grid(640, 360, 1.0, 3).levels, 3);
    EXPECT_THROW(default_grid(64, 48, 0.0), Error);
}

// A coarse mesh over a fine checkerboard: without the prefilter the samples alias to the
// extremes; with it they are close to the local mean.
TEST(Sampling, prefilter_averages_where_cells_are_larger_than_pixels) {
    Image board = make_image(256, 256, 1, SampleFormat::f32);
    for (int y = 0; y < 256; ++y) {
        for (int x = 0; x < 256; ++x) board.at(0, x, y) = ((x + y) & 1) ? 1.0f : 0.0f;
    }
    const Mesh mesh = grid_mesh(256, 256, 2, 2);
    const Hierarchy h = build_hierarchy(mesh, {.levels = 3});  // cells of 32 px
    const auto raw = sample_image(board, h, mesh.vertices, {.prefilter = false});
    const auto filtered = sample_image(board, h, mesh.vertices);
    double raw_dev = 0, filtered_dev = 0;
    for (size_t i = 0; i < raw[0].size(); ++i) {
        raw_dev = std::max(raw_dev, std::abs(raw[0][i] - 0.5));
        filtered_dev = std::max(filtered_dev, std::abs(filtered[0][i] - 0.5));
    }
    EXPECT_GT(raw_dev, 0.4);
    EXPECT_LT(filtered_dev, 0.01);
}

// Cells of at most 1.07 pixels a side (the side of a square of their area) read the image alone
// (one bilinear read, no pyramid); larger ones blend in the 2x2 averages, more the larger they are.
TEST(Sampling, cells_about_a_pixel_read_the_image_alone) {
    // How far the samples of a 16 x 12 grid at J = 4 over a width x height image are from the
    // unfiltered ones, at most.
    const auto differs = [](int width, int height) {
        const Image image = samples::scene_image(width, height);
        const Mesh mesh = grid_mesh(width, height, 16, 12);
        const Hierarchy h = build_hierarchy(mesh, {.levels = 4});
        const auto raw = sample_image(image, h, mesh.vertices, {.prefilter = false});
        const auto filtered = sample_image(image, h, mesh.vertices);
        double most = 0;
        for (int c = 0; c < 3; ++c) {
            for (size_t i = 0; i < raw[c].size(); ++i)
                most = std::max(most, double{std::abs(raw[c][i] - filtered[c][i])});
        }
        return most;
    };
    EXPECT_EQ(differs(256, 192), 0.0);                // cells of 1 x 1 pixel
    EXPECT_EQ(differs(272, 192), 0.0);                // 1.0625 x 1: 1.031 a side
    EXPECT_EQ(differs(274, 205), 0.0);                // 1.070 x 1.068: 1.069 a side
    EXPECT_GT(differs(276, 206), 0.0);                // 1.078 x 1.073: 1.076 a side
    EXPECT_GT(differs(288, 216), differs(276, 206));  // 1.125 x 1.125
    EXPECT_GT(differs(341, 256), 0.01);               // 1.33 x 1.33
    EXPECT_GT(differs(512, 384), differs(341, 256));  // 2 x 2
}

// Every inner node of a quad (the vector rows read those) is the bilinear tap of the image at the
// quad's bilinear map, lerp(lerp(q0, q3, r/m), lerp(q1, q2, r/m), c/m), to the bit: one and three
// channels, and nodes past the image's border (the mesh is stretched over it) clamped.
TEST(Sampling, inner_nodes_are_the_bilinear_tap_to_the_bit) {
    const Mesh mesh = testing::deformed_grid(97, 61, 4, 3, 0.22, 3);
    const Hierarchy h = build_hierarchy(mesh, {.levels = 4});
    std::vector<Vec2> stretched = mesh.vertices;
    for (Vec2& v : stretched) v = {1.1 * v.x - 4.85, 1.1 * v.y - 3.05};
    const std::vector<Quad> quads = t1_quads(h, stretched);
    const int32_t m = h.levels[4].patch_cells, side = m + 1;
    const Image scene = samples::scene_image(97, 61);
    for (int channels : {1, 3}) {
        SCOPED_TRACE(channels);
        Image image = make_image(97, 61, channels, SampleFormat::f32);
        for (int c = 0; c < channels; ++c) image.planes[c] = scene.planes[c];
        const auto got = sample_image(image, h, stretched, {.prefilter = false});
        size_t clamped = 0;
        for (size_t p = 0; p < quads.size(); ++p) {
            const Quad& q = quads[p];
            for (int32_t r = 1; r < m; ++r) {
                const Vec2 left = lerp(q[0], q[3], double(r) / m);
                const Vec2 right = lerp(q[1], q[2], double(r) / m);
                for (int32_t c = 1; c < m; ++c) {
                    const Vec2 at = lerp(left, right, double(c) / m);
                    const Tap tap = bilinear_tap(97, 61, 1.0, at);
                    clamped += at.x < 0.5 || at.y < 0.5 || at.x > 96.5 || at.y > 60.5;
                    const int32_t id = h.levels[4].patch_grid[(p * side + r) * side + c];
                    for (int ch = 0; ch < channels; ++ch) {
                        ASSERT_EQ(got[ch][id], bilinear_at(tap, image.planes[ch].data()))
                            << "quad " << p << " node " << r << "," << c;
                    }
                }
            }
        }
        EXPECT_GT(clamped, 0u);
    }
}

// The vector kernel (four nodes at a time: rows, border lists, pyramid blends) and the scalar one
// give every sample to the bit: inner and border nodes, quads read at one pyramid level and quads
// blending two, grids of 2 to 16 cells a side (rows shorter and longer than four inner nodes),
// a mesh stretched past the image (clamped taps), and one and three channels.
TEST(Sampling, vector_kernel_is_bit_identical_to_the_scalar_one) {
    const Image scene = samples::scene_image(161, 117);
    const Mesh mesh = voronoi_mesh(161, 117, {.sites = 30, .seed = 5});
    std::vector<Vec2> stretched = mesh.vertices;
    for (Vec2& v : stretched) v = {1.08 * v.x - 6.1, 1.08 * v.y - 4.3};
    for (int channels : {1, 3}) {
        Image image = make_image(161, 117, channels, SampleFormat::f32);
        for (int c = 0; c < channels; ++c) image.planes[c] = scene.planes[c];
        for (int levels : {2, 3, 4, 5}) {
            const Hierarchy h = build_hierarchy(mesh, {.levels = levels});
            for (bool prefilter : {false, true}) {
                SCOPED_TRACE(::testing::Message() << channels << " channels, J = " << levels
                                                  << (prefilter ? ", prefiltered" : ""));
                const auto vector = sample_image(image, h, stretched, {.prefilter = prefilter});
                const auto scalar =
                    sample_image(image, h, stretched, {.prefilter = prefilter, .vector = false});
                for (int c = 0; c < channels; ++c) {
                    for (size_t i = 0; i < scalar[c].size(); ++i)
                        ASSERT_EQ(vector[c][i], scalar[c][i])
                            << "channel " << c << ", sample " << i;
                }
            }
        }
    }
    // At J = 5 most quads read the image alone, and the largest blend in the 2x2 averages (7 % of
    // the samples): both kinds were compared above.
    const Hierarchy h = build_hierarchy(mesh, {.levels = 5});
    const auto raw = sample_image(scene, h, stretched, {.prefilter = false});
    const auto filtered = sample_image(scene, h, stretched);
    size_t same = 0;
    for (size_t i = 0; i < raw[0].size(); ++i) same += raw[0][i] == filtered[0][i];
    EXPECT_GT(same, raw[0].size() / 10);
    EXPECT_LT(same, raw[0].size() * 19 / 20);
}

// Quads are shared among the cores; a sample on a border between quads read at different
// pyramid levels is written by one of them, the same whatever the thread count.
TEST(Sampling, samples_are_identical_whatever_the_thread_count) {
    const Image image = samples::scene_image(160, 120);
    const Mesh mesh = voronoi_mesh(160, 120, {.sites = 30, .seed = 4});
    const Hierarchy h = build_hierarchy(mesh, {.levels = 3});  // cells of 2 to 5 pixels
    set_thread_count(1);
    const auto one = sample_image(image, h, mesh.vertices);
    for (int threads : {2, 3}) {
        set_thread_count(threads);
        EXPECT_EQ(sample_image(image, h, mesh.vertices), one) << threads << " threads";
    }
    set_thread_count(0);
}

// The border nodes each quad writes, from T1's topology, are those the last quad holding them in
// its grid would write: checked node by node against the grids themselves, at levels 1 to 3, on
// a grid, a Voronoi mesh and the paper's mesh with features (whose curves split the samples).
TEST(Sampling, each_border_node_is_written_by_the_last_quad_holding_it) {
    for (const Mesh& mesh :
         {grid_mesh(90, 60, 4, 3), voronoi_mesh(160, 120, {.sites = 25, .seed = 2}),
          samples::paper_t0_with_features(100, 80)}) {
        const Hierarchy h = build_hierarchy(mesh, {.levels = 3, .finest_topology = false});
        const std::vector<uint8_t> owns = quad_border_ownership(h);
        ASSERT_EQ(owns.size(), static_cast<size_t>(h.levels[1].num_faces()));
        for (int level = 1; level <= 3; ++level) {
            const LevelTopology& t = h.levels[level];
            const int32_t m = t.patch_cells, side = m + 1;
            std::vector<int32_t> last(static_cast<size_t>(t.n_vertices), -1);
            for (size_t p = 0; p < owns.size(); ++p) {
                for (int32_t i = 0; i < side * side; ++i) {
                    const int32_t r = i / side, c = i % side;
                    if (r == 0 || r == m || c == 0 || c == m)
                        last[t.patch_grid[p * side * side + i]] = static_cast<int32_t>(p);
                }
            }
            for (size_t p = 0; p < owns.size(); ++p) {
                for (int32_t r = 0; r <= m; ++r) {
                    for (int32_t c = 0; c <= m; ++c) {
                        if (r != 0 && r != m && c != 0 && c != m) continue;
                        const int32_t id = t.patch_grid[p * side * side + r * side + c];
                        EXPECT_EQ((owns[p] & border_bit(r, c, m)) != 0,
                                  last[id] == static_cast<int32_t>(p))
                            << "level " << level << ", quad " << p << ", node (" << r << ", " << c
                            << ")";
                    }
                }
            }
        }
    }
}

}  // namespace
}  // namespace tesswave
