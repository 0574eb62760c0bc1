// Internal: the patch-grid numbering of T_j, j >= 1 (see LevelTopology::patch_grid): which edge
// id lies at a grid position, and the refinement T_j -> T_{j+1} that keeps the numbering.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/math/hierarchy.h"

namespace tesswave::detail {

// The T1 edge along each side of a patch (0 bottom r=0, 1 right c=m, 2 top r=m, 3 left c=0) and
// whether it runs in the direction of increasing grid coordinate.
struct PatchSide {
    int32_t edge;
    bool forward;
};

struct PatchSides {
    std::vector<std::array<PatchSide, 4>> sides;  // per patch
    int32_t num_t1_edges = 0;
};

PatchSides patch_sides(const LevelTopology& t1);

inline int32_t side_segment(PatchSide s, int32_t t, int32_t m) {
    return s.edge * m + (s.forward ? t : m - 1 - t);
}

// Edge (r,c)-(r,c+1) of patch p in a level with m cells a side; 0 <= r <= m, 0 <= c < m.
inline int32_t horizontal_edge(const PatchSides& ps, int32_t p, int32_t r, int32_t c, int32_t m) {
    if (r == 0) return side_segment(ps.sides[p][0], c, m);
    if (r == m) return side_segment(ps.sides[p][2], c, m);
    return ps.num_t1_edges * m + p * 2 * m * (m - 1) + (r - 1) * m + c;
}

// Edge (r,c)-(r+1,c) of patch p; 0 <= r < m, 0 <= c <= m.
inline int32_t vertical_edge(const PatchSides& ps, int32_t p, int32_t r, int32_t c, int32_t m) {
    if (c == 0) return side_segment(ps.sides[p][3], r, m);
    if (c == m) return side_segment(ps.sides[p][1], r, m);
    return ps.num_t1_edges * m + p * 2 * m * (m - 1) + m * (m - 1) + r * (m - 1) + (c - 1);
}

// Sets up the grids of T1 (m = 1) from its topology, which already has the patch numbering.
void init_patch_grids(LevelTopology& t1, const PatchSides& ps);

// T_j -> T_{j+1} for j >= 1, numbered by patch grids; without `topology`, only the counts,
// kinds, skeleton and patch grids (LevelTopology::topology false).
LevelTopology refine_patches(const LevelTopology& t, const PatchSides& ps, bool topology = true);

}  // namespace tesswave::detail
