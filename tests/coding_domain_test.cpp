// The coding domain's 9/7 on the lattice of a grid mesh's samples: the lattice index, the
// transform against the fixed-grid 9/7 on samples placed by their positions, and exact inversion.
#include "core/codec/coding_domain.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "core/math/colour.h"
#include "core/math/error.h"
#include "core/math/grid_mesh.h"
#include "core/math/hierarchy.h"
#include "core/math/voronoi.h"
#include "samples/sample_images.h"

namespace tesswave {
namespace {

TEST(GridLattice, EverySampleHasItsOwnLatticePoint) {
    const int cols = 3, rows = 2, J = 2;
    const Mesh grid = grid_mesh(60, 30, cols, rows);
    const Hierarchy h = build_hierarchy(grid, {.levels = J});
    const std::vector<int32_t> index = grid_lattice_index(h, cols, rows);
    const int width = (cols << J) + 1, height = (rows << J) + 1;
    ASSERT_EQ(index.size(), static_cast<size_t>(width * height));
    std::vector<int32_t> sorted = index;
    std::sort(sorted.begin(), sorted.end());
    for (int32_t k = 0; k < width * height; ++k) ASSERT_EQ(sorted[k], k);
    // Each sample's lattice point is where it sits at rest: 5 pixels a lattice step in x, 3.75 in
    // y.
    const std::vector<Vec2> p = refine_positions(h, grid.vertices, J);
    for (size_t i = 0; i < p.size(); ++i) {
        EXPECT_DOUBLE_EQ(p[i].x, 5.0 * (index[i] % width)) << i;
        EXPECT_DOUBLE_EQ(p[i].y, 3.75 * (index[i] / width)) << i;
    }
    // A mesh of another topology has no lattice.
    const Hierarchy other = build_hierarchy(voronoi_mesh(60, 30, {.sites = 6}), {.levels = J});
    EXPECT_THROW(grid_lattice_index(other, cols, rows), Error);
    EXPECT_THROW(grid_lattice_index(h, rows, cols), Error);
}

DomainShape lattice_shape(const Mesh& mesh, int cols, int rows, MeshWavelet wavelet) {
    return {.transform = TwiTransform::mesh,
            .width = 48,
            .height = 40,
            .channels = 3,
            .colour = TwiColour::ycbcr,
            .levels = 3,
            .mesh = mesh,
            .channel_factors = {1, 1, 1},
            .mesh_wavelet = wavelet,
            .grid_cols = cols,
            .grid_rows = rows};
}

// The coefficients are the fixed-grid 9/7 of the samples placed on the lattice by where they sit
// in the image, whatever the vertex positions (the lattice is the mesh's parameter domain).
TEST(LatticeWavelet, IsTheGridWaveletOfTheSamplesInTheirPlaces) {
    const Image image = samples::noise_image(48, 40);
    const Mesh rest = grid_mesh(48, 40, 4, 3);
    const CodingDomain domain(lattice_shape(rest, 4, 3, MeshWavelet::lattice97), 1);
    const int width = (4 << 3) + 1, height = (3 << 3) + 1;
    ASSERT_EQ(domain.size(), width * height);
    EXPECT_EQ(domain.layout().bands.size(), 1u + 3 * 3);

    std::vector<Vec2> moved = rest.vertices;
    moved[6] = moved[6] + Vec2{2.5, -1.25};  // an inner vertex
    Planes samples;
    domain.sample(image, moved, samples);
    Planes coefficients = samples;
    domain.analyze_samples(coefficients);

    const std::vector<Vec2> at_rest = refine_positions(*domain.hierarchy(), rest.vertices, 3);
    const double dx = 48.0 / (width - 1), dy = 40.0 / (height - 1);
    ycbcr_forward(samples[0], samples[1], samples[2]);
    for (int c = 0; c < 3; ++c) {
        std::vector<float> lattice(samples[c].size());
        for (size_t i = 0; i < at_rest.size(); ++i) {
            const auto x = std::lround(at_rest[i].x / dx), y = std::lround(at_rest[i].y / dy);
            lattice[y * width + x] = samples[c][i];
        }
        grid_forward(lattice, width, height, {.wavelet = GridWavelet::cdf97, .levels = 3});
        for (size_t k = 0; k < lattice.size(); ++k) {
            ASSERT_NEAR(coefficients[c][k], lattice[k], 1e-5) << "channel " << c << ", " << k;
        }
    }
}

// Unquantized, both wavelets give back the samples: the same rendered image.
TEST(LatticeWavelet, SynthesisInvertsAnalysis) {
    const Image image = samples::scene_image(48, 40, 5);
    const Mesh rest = grid_mesh(48, 40, 4, 3);
    std::vector<Vec2> moved = rest.vertices;
    moved[7] = moved[7] + Vec2{-1.5, 2.0};
    Image lattice_image, lifted_image;
    for (MeshWavelet w : {MeshWavelet::lattice97, MeshWavelet::lifted}) {
        const CodingDomain domain(lattice_shape(rest, 4, 3, w), 1);
        Planes x;
        domain.analyze(image, moved, x, Sampling::fit);
        domain.synthesize(std::move(x), moved,
                          w == MeshWavelet::lattice97 ? lattice_image : lifted_image);
    }
    for (int c = 0; c < 3; ++c) {
        for (size_t i = 0; i < lattice_image.planes[c].size(); ++i) {
            ASSERT_NEAR(lattice_image.planes[c][i], lifted_image.planes[c][i], 2e-5) << i;
        }
    }
}

TEST(LatticeWavelet, NeedsAGridMesh) {
    const Mesh voronoi = voronoi_mesh(48, 40, {.sites = 8});
    EXPECT_THROW(CodingDomain(lattice_shape(voronoi, 4, 3, MeshWavelet::lattice97), 1), Error);
    const Mesh grid = grid_mesh(48, 40, 4, 3);
    EXPECT_THROW(CodingDomain(lattice_shape(grid, 3, 4, MeshWavelet::lattice97), 1), Error);
    EXPECT_THROW(CodingDomain(lattice_shape(grid, 0, 0, MeshWavelet::lattice97), 1), Error);
    // Lossless coding keeps the lifted wavelet.
    const CodingDomain domain(lattice_shape(grid, 4, 3, MeshWavelet::lattice97), 1);
    EXPECT_THROW(domain.analyze_int(samples::scene_image(48, 40, 1)), Error);
}

// An encoder's band norms can be those of the rendered image: the renderer's bilinear interpolation
// damps the finest bands of a mesh about as fine as the pixels (and not aligned with them), most
// of all the diagonal ones, while coarse bands keep the norms of their samples. Decoders take the
// norms they are given.
TEST(BandNorms, AreWeighedByRendering) {
    const int width = 64, height = 48, J = 4;
    const Mesh grid = grid_mesh(width, height, 4, 3);
    DomainShape shape = lattice_shape(grid, 4, 3, MeshWavelet::lattice97);
    shape.width = width, shape.height = height, shape.levels = J;
    const int lw = (4 << J) + 1, lh = (3 << J) + 1;  // 65 x 49 samples for 64 x 48 pixels
    const double unit = std::sqrt(double{width} * height / (lw * lh));
    for (MeshWavelet wavelet : {MeshWavelet::lattice97, MeshWavelet::lifted}) {
        SCOPED_TRACE(static_cast<int>(wavelet));
        shape.mesh_wavelet = wavelet;
        const CodingDomain domain(shape, 1, {}, BandNorms::rendered);
        const CodingLayout samples_norms =
            wavelet == MeshWavelet::lattice97
                ? grid_layout(lw, lh, J, GridWavelet::cdf97)
                : mesh_layout(*domain.hierarchy(), double{width} * height, 1);
        const auto& bands = domain.layout().bands;
        ASSERT_EQ(bands.size(), samples_norms.bands.size());
        std::vector<double> ratio;
        for (size_t b = 0; b < bands.size(); ++b) {
            const double reference =
                samples_norms.bands[b].norm * (wavelet == MeshWavelet::lattice97 ? unit : 1.0);
            ratio.push_back(bands[b].norm / reference);
            EXPECT_LE(ratio.back(), 1.01) << b;
            EXPECT_GT(ratio.back(), 0.0) << b;
        }
        // The coarsest band: within 2 % (its samples' energy counts the border samples as whole
        // ones, and 65 x 49 samples stand for 64 x 48 pixels).
        EXPECT_NEAR(ratio[0], 1.0, 0.02);
        const size_t n = bands.size();
        if (wavelet == MeshWavelet::lattice97) {  // the finest level's H, V and D
            EXPECT_LT(ratio[n - 3], 0.9);
            EXPECT_LT(ratio[n - 2], 0.9);
            EXPECT_LT(ratio[n - 1], std::min(ratio[n - 3], ratio[n - 2]));
        } else {  // the finest level's edge and face points
            EXPECT_LT(ratio[n - 2], 0.95);
            EXPECT_LT(ratio[n - 1], 0.95);
        }
        // The samples' norms, unless asked.
        const CodingDomain unweighed(shape, 1);
        for (size_t b = 0; b < n; ++b) {
            const double reference =
                samples_norms.bands[b].norm * (wavelet == MeshWavelet::lattice97 ? unit : 1.0);
            EXPECT_NEAR(unweighed.layout().bands[b].norm, reference, 1e-9 * reference) << b;
        }
        // The shared cache tells the two apart.
        const auto rendered = shared_domain(shape, 1, {}, BandNorms::rendered);
        const auto plain = shared_domain(shape, 1);
        EXPECT_EQ(rendered->layout().bands[n - 1].norm, bands[n - 1].norm);
        EXPECT_EQ(plain->layout().bands[n - 1].norm, unweighed.layout().bands[n - 1].norm);
        // A decoder keeps the norms it reads.
        std::vector<float> given;
        for (const CodingBand& b : bands) given.push_back(static_cast<float>(b.norm));
        const CodingDomain decoder(shape, 0, given);
        for (size_t b = 0; b < n; ++b) EXPECT_EQ(decoder.layout().bands[b].norm, given[b]);
    }
}

}  // namespace
}  // namespace tesswave
