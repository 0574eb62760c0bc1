#include "core/codec/still_codec.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>

#include "core/codec/coding_domain.h"
#include "core/math/error.h"
#include "core/math/grid_mesh.h"
#include "core/math/hierarchy.h"
#include "core/math/metrics.h"
#include "core/math/parallel.h"
#include "samples/sample_images.h"
#include "samples/sample_meshes.h"
#include "test_meshes.h"

namespace tesswave {
namespace {

// The procedural scene with `channels` channels, quantized to 8 bits like a file's pixels (an
// alpha channel is a soft disc).
Image scene(int w, int h, int channels) {
    const Image rgb = samples::scene_image(w, h);
    Image image = make_image(w, h, channels);
    for (int c = 0; c < channels; ++c) {
        for (int y = 0; y < h; ++y) {
            for (int x = 0; x < w; ++x) {
                float v = rgb.at(std::min(c, 2), x, y);
                if (c == 3)
                    v = std::clamp(1.5f - std::hypot(x - w / 2.0f, y - h / 2.0f) / (0.3f * w), 0.0f,
                                   1.0f);
                image.at(c, x, y) = std::round(std::clamp(v, 0.0f, 1.0f) * 255.0f) / 255.0f;
            }
        }
    }
    return image;
}

std::vector<int> bytes_of(const Image& image) {
    std::vector<int> out;
    for (const auto& plane : image.planes) {
        for (float v : plane) out.push_back(static_cast<int>(std::lround(v * 255.0f)));
    }
    return out;
}

double quality(const Image& a, const Image& b) { return psnr(a, b).all; }

TEST(StillCodec, lossless_grid_53_round_trip_is_bit_exact) {
    for (int channels : {1, 3, 4}) {
        for (auto [w, h] :
             {std::pair{37, 23}, std::pair{64, 48}, std::pair{1, 9}, std::pair{2, 1}}) {
            SCOPED_TRACE(::testing::Message() << channels << " channels, " << w << "x" << h);
            const Image image = scene(w, h, channels);
            const StillResult r =
                compress_image(image, {.transform = TwiTransform::grid53, .lossless = true});
            const Image back = decompress_image(r.file, "test");
            ASSERT_EQ(back.channels(), channels);
            EXPECT_EQ(bytes_of(back), bytes_of(image));
        }
    }
}

TEST(StillCodec, lossless_on_an_aligned_grid_mesh_round_trips_the_image_bit_exactly) {
    for (int channels : {1, 3, 4}) {
        for (auto [w, h] :
             {std::pair{65, 33}, std::pair{33, 49}, std::pair{64, 48}, std::pair{1, 7}}) {
            SCOPED_TRACE(::testing::Message() << channels << " channels, " << w << "x" << h);
            const Image image = scene(w, h, channels);
            const StillResult r = compress_image(image, {.lossless = true, .aligned = true});
            EXPECT_EQ(r.header.placement, MeshPlacement::centres);
            EXPECT_EQ(bytes_of(decompress_image(r.file, "test")), bytes_of(image));
        }
    }
}

TEST(StillCodec, lossless_mesh_round_trips_its_samples_bit_exactly) {
    const Image image = scene(61, 47, 3);
    for (const Mesh& mesh :
         {Mesh{}, samples::paper_t0(61, 47), samples::paper_t0_with_features(61, 47)}) {
        const StillResult r = compress_image(image, {.lossless = true, .mesh = mesh, .levels = 3});
        EXPECT_EQ(decode_lossless_samples(r.file), lossless_samples(image, r.header));
    }
}

TEST(StillCodec, byte_budget_is_met_exactly) {
    const Image image = scene(96, 64, 3);
    for (TwiTransform t : {TwiTransform::mesh, TwiTransform::grid53, TwiTransform::grid97}) {
        for (int64_t budget : {200, 700, 1500}) {
            const StillResult r = compress_image(image, {.transform = t, .max_bytes = budget});
            EXPECT_EQ(static_cast<int64_t>(r.file.size()), budget);
        }
    }
}

TEST(StillCodec, every_prefix_of_a_small_stream_decodes) {
    const Image image = scene(24, 20, 3);
    for (TwiTransform t : {TwiTransform::mesh, TwiTransform::grid97}) {
        for (bool lossless : {false, true}) {
            if (lossless && t == TwiTransform::grid97) continue;
            const StillResult r = compress_image(
                image, {.transform = t, .lossless = lossless, .max_bytes = lossless ? 0 : 600});
            for (size_t n = r.header.header_bytes; n <= r.file.size(); ++n) {
                const Image out = decompress_image(r.file, "prefix", {.max_bytes = n});
                ASSERT_EQ(out.width, 24);
                ASSERT_EQ(out.channels(), 3);
            }
            for (size_t n = 0; n < r.header.header_bytes; ++n) {
                EXPECT_THROW(decompress_image(r.file, "prefix", {.max_bytes = n}), Error);
            }
        }
    }
}

TEST(StillCodec, quality_rises_with_the_bytes_decoded) {
    const Image image = scene(128, 96, 3);
    for (TwiTransform t : {TwiTransform::mesh, TwiTransform::grid53, TwiTransform::grid97}) {
        const StillResult r = compress_image(image, {.transform = t, .max_bytes = 4000});
        double last = 0;
        for (size_t n = r.header.header_bytes + 16;; n = std::min(n * 5 / 4, r.file.size())) {
            const double q = quality(image, decompress_image(r.file, "prefix", {.max_bytes = n}));
            EXPECT_GE(q, last) << n << " bytes";
            last = q;
            if (n == r.file.size()) break;
        }
        EXPECT_EQ(last, r.psnr);
    }
}

// Size and quality of a fixed procedural image, pinned from both sides: a coder change that makes
// them worse fails, and so does one that makes them much better (update the pins then).
struct Pin {
    TwiTransform transform;
    double bpp, psnr;
    Sampling sampling = Sampling::point;
    MeshWavelet wavelet = MeshWavelet::lifted;
};

TEST(StillCodec, pinned_quality_at_three_rates) {
    const Image image = scene(128, 96, 3);
    // The range coder's models learn fast while fresh (range_coder.h): 0.5 to 3 dB more on this
    // small image than with models starting at 1/2 (mesh 21.50 / 27.83 / 30.49 dB before). The
    // lifted mesh rows lost a byte of stream to version 3's wavelet byte (24.536 dB at 0.25 bpp,
    // 28.897 at 0.5 with fit, before). Band norms weighed by rendering (coding_domain.cpp) moved
    // the mesh rows at 0.5 / 1 bpp: point 28.447 / 30.979, fit 28.800 / 33.508, the lattice
    // 25.303 / 29.823 / 34.200 at 0.25 / 0.5 / 1, before. The default density went from 1 to 1.25
    // (kStillDensity; an 18x13 T0 where it was 16x12 on this image): the mesh rows were point
    // 24.483 / 28.373 / 30.860, fit 24.483 / 29.486 / 34.040, the lattice 25.369 / 29.982 /
    // 34.566 at density 1 (at 0.25 bpp, 384 bytes, the larger base level costs on so small an
    // image; on Kodak it is neutral there).
    const Pin pins[] = {
        {TwiTransform::mesh, 0.25, 23.733},
        {TwiTransform::mesh, 0.5, 28.210},
        {TwiTransform::mesh, 1, 32.425},
        {TwiTransform::mesh, 0.25, 23.733, Sampling::fit},
        {TwiTransform::mesh, 0.5, 29.379, Sampling::fit},
        {TwiTransform::mesh, 1, 34.811, Sampling::fit},
        {TwiTransform::grid53, 0.25, 25.416},
        {TwiTransform::grid53, 0.5, 30.679},
        {TwiTransform::grid53, 1, 36.396},
        {TwiTransform::grid97, 0.25, 25.687},
        {TwiTransform::grid97, 0.5, 30.835},
        {TwiTransform::grid97, 1, 36.088},
        // The 9/7 on the grid mesh's lattice (the default since .twi version 3).
        {TwiTransform::mesh, 0.25, 24.905, Sampling::fit, MeshWavelet::lattice97},
        {TwiTransform::mesh, 0.5, 30.246, Sampling::fit, MeshWavelet::lattice97},
        {TwiTransform::mesh, 1, 35.518, Sampling::fit, MeshWavelet::lattice97},
    };
    for (const Pin& pin : pins) {
        const int64_t budget = static_cast<int64_t>(pin.bpp * 128 * 96 / 8);
        const StillResult r = compress_image(image, {.transform = pin.transform,
                                                     .max_bytes = budget,
                                                     .mesh_wavelet = pin.wavelet,
                                                     .sampling = pin.sampling});
        EXPECT_EQ(static_cast<int64_t>(r.file.size()), budget);
        EXPECT_NEAR(r.psnr, pin.psnr, 0.05) << int(pin.transform) << " at " << pin.bpp << " bpp, "
                                            << sampling_name(pin.sampling) << ": " << r.psnr;
    }
}

TEST(StillCodec, pinned_sizes_for_three_quality_targets) {
    const Image image = scene(128, 96, 3);
    for (auto [target, bytes] :
         {std::pair{26.0, 403}, std::pair{30.0, 682}, std::pair{34.0, 1138}}) {
        const StillResult r =
            compress_image(image, {.transform = TwiTransform::grid97, .target_psnr = target});
        EXPECT_GE(r.psnr, target);
        EXPECT_LT(r.psnr, target + 0.3);
        EXPECT_NEAR(static_cast<double>(r.file.size()), bytes, 0.02 * bytes)
            << target << " dB: " << r.file.size();
    }
}

// A target the mesh cannot reach (its resampling caps it: half a sample a pixel) keeps the whole
// stream and says so; the file is then exactly the one coded at the target's step with no rate
// search. (At the default density the projection renders this scene exactly.)
TEST(StillCodec, an_unreachable_target_keeps_the_whole_stream_and_says_so) {
    const Image image = scene(128, 96, 3);
    const StillResult capped = compress_image(image, {.target_psnr = 80, .density = 0.5});
    EXPECT_FALSE(capped.target_reached);
    EXPECT_LT(capped.psnr, 80);
    const StillResult whole =
        compress_image(image, {.base_step = step_for_psnr(80 + 6), .density = 0.5});
    EXPECT_EQ(capped.file, whole.file);
    const StillResult reached =
        compress_image(image, {.target_psnr = capped.psnr - 3, .density = 0.5});
    EXPECT_TRUE(reached.target_reached);
    EXPECT_GE(reached.psnr, capped.psnr - 3);
    EXPECT_LT(reached.file.size(), capped.file.size());
}

// On a grid mesh whose finest vertices are the pixels, the lifted bilinear transform is the
// separable 5/3 away from the border (the mesh takes 1D rules along the border where the grid
// extends symmetrically), so the two paths of the codec see the same coefficients there.
TEST(StillCodec, fixed_grid_53_equals_the_mesh_path_on_a_pixel_aligned_grid_mesh) {
    const int n = 129, J = 4;  // 129 = 8 * 2^4 + 1: no padding
    Image image = scene(n, n, 1);
    TwiHeader mesh_h;
    mesh_h.placement = MeshPlacement::centres;
    mesh_h.width = mesh_h.height = n;
    mesh_h.levels = J;
    mesh_h.grid_cols = mesh_h.grid_rows = aligned_cells(n, J);
    mesh_h.mesh = grid_mesh(n - 1, n - 1, mesh_h.grid_cols, mesh_h.grid_rows);
    TwiHeader grid_h = mesh_h;
    grid_h.transform = TwiTransform::grid53;
    const std::vector<float> mesh = CodingDomain(still_shape(mesh_h), 0).analyze(image)[0];
    const std::vector<float> grid = CodingDomain(still_shape(grid_h), 0).analyze(image)[0];
    const Hierarchy hierarchy = build_hierarchy(mesh_h.mesh, {.levels = J});
    const std::vector<Vec2> pos = refine_positions(hierarchy, mesh_h.mesh.vertices, J);
    int compared = 0, near_border = 0;
    for (size_t i = 0; i < pos.size(); ++i) {
        const int x = static_cast<int>(std::lround(pos[i].x)),
                  y = static_cast<int>(std::lround(pos[i].y));
        const int L = std::min(std::countr_zero(static_cast<unsigned>(x | y | 1024)), J) + 1;
        if (L > J) continue;  // a coarse (LL) sample
        // Its place in the Mallat layout: the level-L band of the region left by L - 1 levels.
        int w = n, col = x, row = y;
        for (int l = 1; l < L; ++l) w = (w + 1) / 2;
        const int low = (w + 1) / 2, X = x >> (L - 1), Y = y >> (L - 1);
        col = X % 2 ? low + X / 2 : X / 2;
        row = Y % 2 ? low + Y / 2 : Y / 2;
        const int margin = 2 << L;  // the border's reach: two cells of the level (1 << L fails)
        if (std::min({x, y, n - 1 - x, n - 1 - y}) < margin) {
            ++near_border;
            continue;
        }
        ASSERT_NEAR(mesh[i], grid[row * n + col], 2e-6)
            << "pixel " << x << "," << y << " level " << L;
        ++compared;
    }
    EXPECT_GT(compared, n * n / 2);
    EXPECT_GT(near_border, 0);
}

// What compress_image refuses for its size is refused from the size alone (the command checks a
// file's declared size with it before reading the pixels): an 8192x8192 image's default mesh has
// more samples than the limit; a side over the limit; J = 11 on a 64x48 image.
TEST(StillCodec, sizes_are_refused_before_any_pixel) {
    EXPECT_NE(testing::error_of([] { check_still_size(8192, 8192, 3, {}); }).find("samples"),
              std::string::npos);
    EXPECT_NE(testing::error_of([] { check_still_size(70000, 8, 1, {}); }).find("side"),
              std::string::npos);
    EXPECT_NO_THROW(check_still_size(8192, 8192, 3, {.transform = TwiTransform::grid97}));
    EXPECT_NO_THROW(check_still_size(640, 480, 4, {}));
    const StillOptions deep{.levels = 11};
    const std::string early = testing::error_of([&] { check_still_size(64, 48, 3, deep); });
    EXPECT_NE(early.find("samples"), std::string::npos) << early;
    EXPECT_EQ(early, testing::error_of([&] { compress_image(scene(64, 48, 3), deep); }));
}

// The file is the same to the byte on any thread count (the projections, the transform, the
// rendering and the candidates' measurements share their work among the threads, the candidates
// are coded side by side, and a new domain weighs its bands' norms side by side), at a size, at a
// quality target and with neither.
TEST(StillCodec, the_same_file_whatever_the_thread_count) {
    const Image image = scene(96, 80, 3);
    for (const StillOptions& o :
         {StillOptions{.max_bytes = 960}, StillOptions{.target_psnr = 30}, StillOptions{}}) {
        set_thread_count(1);
        clear_domain_cache();  // each count builds its domain (the norms weighed by rendering)
        const StillResult one = compress_image(image, o);
        EXPECT_NE(one.sampling, "point");  // a projection won: more than one candidate was coded
        for (const int threads : {2, 3}) {
            set_thread_count(threads);
            clear_domain_cache();
            const StillResult many = compress_image(image, o);
            EXPECT_EQ(many.file, one.file) << threads << " threads";
            EXPECT_EQ(many.sampling, one.sampling) << threads << " threads";
        }
    }
    set_thread_count(0);
}

// Coding and decoding give the same file and image to the bit on any thread count (the planes
// transformed, quantized, dequantized and synthesized side by side), on the mesh and on both
// fixed grids.
TEST(StillCodec, the_same_image_whatever_the_thread_count) {
    const Image image = scene(96, 80, 3);
    for (const TwiTransform t : {TwiTransform::mesh, TwiTransform::grid97, TwiTransform::grid53}) {
        set_thread_count(1);
        const StillResult r = compress_image(image, {.transform = t, .max_bytes = 960});
        const Image one = decompress_image(r.file, "test.twi");
        for (const int threads : {2, 3}) {
            set_thread_count(threads);
            clear_domain_cache();
            EXPECT_EQ(compress_image(image, {.transform = t, .max_bytes = 960}).file, r.file)
                << static_cast<int>(t) << ", " << threads << " threads";
            EXPECT_EQ(decompress_image(r.file, "test.twi").planes, one.planes)
                << static_cast<int>(t) << ", " << threads << " threads";
        }
    }
    set_thread_count(0);
}

// The domain cache hands back the domain it holds for an equal shape, probe count and norms,
// builds a new one for any difference, keeps at most four, and a cached decode equals a fresh one.
TEST(StillCodec, domains_are_cached_by_shape_probes_and_norms) {
    clear_domain_cache();
    const Image image = scene(48, 40, 3);
    const StillResult coded =
        compress_image(image, {.transform = TwiTransform::mesh, .max_bytes = 400});
    const DomainShape shape = still_shape(coded.header);
    const std::span<const float> norms = coded.header.band_norms;
    const auto first = shared_domain(shape, 0, norms);
    EXPECT_EQ(shared_domain(shape, 0, norms), first);

    DomainShape moved = shape;
    moved.mesh.vertices[5].x += 0.5;
    EXPECT_NE(shared_domain(moved, 0, norms), first);
    std::vector<float> other_norms(norms.begin(), norms.end());
    other_norms[0] *= 2;
    EXPECT_NE(shared_domain(shape, 0, other_norms), first);
    EXPECT_NE(shared_domain(shape, 1), first);
    EXPECT_EQ(shared_domain(shape, 0, norms), first);  // four held: still there

    DomainShape fifth = shape;
    fifth.channel_factors[0] *= 2;
    shared_domain(fifth, 0, norms);  // the least recently used (moved) leaves
    EXPECT_EQ(shared_domain(shape, 0, norms), first);

    // A decode through the cache equals one through a fresh domain.
    const Image cached = decompress_image(coded.file, "scene.twi", {});
    clear_domain_cache();
    EXPECT_EQ(bytes_of(decompress_image(coded.file, "scene.twi", {})), bytes_of(cached));
    EXPECT_NE(shared_domain(shape, 0, norms), first);  // cleared: built anew
}

}  // namespace
}  // namespace tesswave
