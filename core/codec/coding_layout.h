// How the embedded coder walks a transform's coefficients (DESIGN.md 2.6): bands in coding order
// (coarse first) with the L2 norm of their basis functions, and for every coefficient the
// neighbours and parents whose significance chooses its probability contexts. The coder sees only
// this description, so one coder serves the mesh transform and the fixed-grid wavelets.
#pragma once

#include <cstdint>
#include <vector>

#include "core/math/fixed_grid.h"
#include "core/math/hierarchy.h"

namespace tesswave {

struct CodingBand {
    // Mesh: the decomposition step (T_{level+1} -> T_level) and 'e' (edge points) or 'f' (face
    // points); the base band (the T0 values) is level -1, type 'v'. Grid: the level (1 finest) and
    // 'L' (LL), 'H' (HL), 'V' (LH), 'D' (HH).
    int level = 0;
    char type = 'v';
    int32_t begin = 0, end = 0;  // positions in CodingLayout::order
    // L2 norm of a basis function of the band in the image, in units where a pixel has area 1:
    // a coefficient error e costs about e^2 norm^2 of squared pixel error.
    double norm = 1.0;
};

struct CodingLayout {
    int32_t size = 0;            // coefficients per plane
    std::vector<int32_t> order;  // coefficient ids, band after band
    std::vector<CodingBand> bands;
    // Per position k of `order`: neighbours at the same level [nb_offsets[k], nb_offsets[k+1])
    // and parents at coarser levels [pa_offsets[k], pa_offsets[k+1]), as coefficient ids.
    // The first nb_primary[k] neighbours are the primary ones (those along which the band's
    // coefficients correlate most); the coder counts primary and other neighbours apart.
    std::vector<int32_t> nb_offsets, nb, pa_offsets, pa;
    std::vector<uint8_t> nb_primary;
    // Per coefficient id: the coefficients it is a parent of [ch_offsets[i], ch_offsets[i+1]).
    std::vector<int32_t> ch_offsets, ch;
    // Fixed-grid layouts without lists (grid_layout's default): the bands' rectangles in the
    // Mallat plane `grid_width` coefficients wide, one per entry of `bands`, and per band the band
    // of its children (-1: none). The coder computes the relations from them, and the lists above
    // stay empty: they would take 53 bytes a coefficient, 3.6 GB for an 8192x8192 plane (whose
    // channels share them).
    int32_t grid_width = 0;
    std::vector<GridBand> grid_bands;
    std::vector<int32_t> grid_child_band;
};

// The mesh transform of a hierarchy down to T0 (lifting.h layout). A band's norm is the mean
// over `probes` unit impulses spread through it, reconstructed to T_J, each sample standing for
// domain_area / |V_J| pixels (probes = 0: norms left at 1, for decoders that read them).
// Neighbours of an edge point: the opposite edge points of its faces with an even corner count
// (primary; on a grid these are EBCOT's), then its face points and its faces' other edge points;
// of a face point: the face points across its edges (primary), then its edge points.
// Parents: the edge's endpoints, the face's corners (detail coefficients only).
CodingLayout mesh_layout(const Hierarchy& hierarchy, double domain_area, int probes = 1);

// How a fixed-grid layout gives its relations: computed by the coder from the bands' rectangles,
// or listed as a mesh's are (the reference the computed ones are tested against).
enum class GridRelations : uint8_t { computed, listed };

// Whether the neighbour (dx, dy) of a coefficient in a grid band of GridBand::type `type` is a
// primary one (EBCOT's: horizontal in LL and LH, vertical in HL, diagonal in HH).
inline bool grid_primary(int type, int dx, int dy) {
    return type == 3 ? (dx && dy) : type == 1 ? (!dx && dy) : (dx && !dy);
}

// The fixed-grid wavelet of a width x height plane (fixed_grid.h Mallat layout; grid_bands order).
// Neighbours: the 8 around a coefficient inside its band, primary as in EBCOT: the horizontal
// ones in LL and LH, the vertical ones in HL, the diagonal ones in HH. Parent: the coefficient of
// the same orientation one level coarser, at (min(x / 2, w - 1), min(y / 2, h - 1)) in that band
// of w x h.
// Norms from centre impulses when `norms` (else 1, for decoders that read them).
CodingLayout grid_layout(int width, int height, int levels, GridWavelet wavelet, bool norms = true,
                         GridRelations relations = GridRelations::computed);

// Calls row(first, width) for every row of band b where the layout is a grid's (its bands are
// rectangles of the Mallat plane: each row's coefficients lie side by side, so the row loops
// vectorize), else one(id) for each of its coefficients in coding order.
template <class Row, class One>
void for_band(const CodingLayout& layout, size_t b, Row&& row, One&& one) {
    if (!layout.grid_bands.empty()) {
        const GridBand& r = layout.grid_bands[b];
        for (int y = r.y0; y < r.y0 + r.height; ++y)
            row(static_cast<size_t>(y) * layout.grid_width + r.x0, r.width);
        return;
    }
    for (int32_t k = layout.bands[b].begin; k < layout.bands[b].end; ++k) one(layout.order[k]);
}

}  // namespace tesswave
