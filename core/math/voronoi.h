// Random Voronoi tessellations of the domain [0,W]x[0,H], optionally Lloyd-relaxed: the standard
// procedural T0 (DESIGN.md 2.1) for tests, benchmarks and examples.
#pragma once

#include <cstdint>

#include "core/math/mesh.h"

namespace tesswave {

struct VoronoiOptions {
    int sites = 64;            // number of cells, 1 .. 10'000'000
    uint64_t seed = 1;         // seed of std::mt19937_64; one seed gives one mesh on every platform
    int lloyd_iterations = 0;  // moves of every site to its cell's area centroid, 0 .. 10'000
};

// Face f is the Voronoi cell of site s_f clipped to the domain, {p : |p - s_f| <= |p - s_g| for all
// g}, listed counterclockwise in (x, y). Sites start uniform and distinct: s = (W u, H v) with
// u = (r >> 11) * 2^-53 for successive outputs r of mt19937_64(seed), so no standard library
// distribution is involved. Each Lloyd iteration replaces s_f by the area centroid of cell f.
// Vertices closer than 4e-9 of the domain diagonal are welded into one, so the result has no
// vanishing edges. Throws Error for bad arguments, and in the (never observed) case that floating
// point cannot resolve a degenerate site configuration into a valid tessellation.
Mesh voronoi_mesh(double width, double height, const VoronoiOptions& options = {});

}  // namespace tesswave
