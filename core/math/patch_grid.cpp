#include "core/math/patch_grid.h"

namespace tesswave::detail {

PatchSides patch_sides(const LevelTopology& t1) {
    PatchSides ps;
    ps.num_t1_edges = t1.num_edges();
    ps.sides.resize(t1.num_faces());
    for (int32_t p = 0; p < t1.num_faces(); ++p) {
        const int32_t* a = &t1.face_v[4 * p];
        const int32_t* e = &t1.face_e[4 * p];
        // The grid coordinate grows from a0 along the bottom and left sides, from a1 along the
        // right side and from a3 along the top.
        const int32_t start[4] = {a[0], a[1], a[3], a[0]};
        for (int s = 0; s < 4; ++s) ps.sides[p][s] = {e[s], t1.edge_v[e[s]][0] == start[s]};
    }
    return ps;
}

void init_patch_grids(LevelTopology& t1, const PatchSides& ps) {
    t1.patch_cells = 1;
    t1.patch_grid.resize(4 * ps.sides.size());
    for (size_t p = 0; p < ps.sides.size(); ++p) {
        const int32_t* a = &t1.face_v[4 * p];
        t1.patch_grid[4 * p + 0] = a[0];
        t1.patch_grid[4 * p + 1] = a[1];
        t1.patch_grid[4 * p + 2] = a[3];
        t1.patch_grid[4 * p + 3] = a[2];
    }
    t1.skeleton.resize(2 * ps.num_t1_edges);
    for (int32_t i = 0; i < ps.num_t1_edges; ++i) {
        t1.skeleton[2 * i] = t1.edge_v[i][0];
        t1.skeleton[2 * i + 1] = t1.edge_v[i][1];
    }
    t1.patch_interior.assign(t1.n_vertices, 0);
}

namespace {

// Faces, edges and their adjacency of a level from its grids and skeleton.
void topology_from_grids(LevelTopology& t, const PatchSides& ps) {
    const int32_t m = t.patch_cells, P = static_cast<int32_t>(ps.sides.size());
    const int32_t E1 = ps.num_t1_edges, S = E1 * m, F = P * m * m;
    const size_t side = m + 1;
    t.face_offsets.resize(F + 1);
    for (int32_t k = 0; k <= F; ++k) t.face_offsets[k] = 4 * k;
    t.face_v.resize(4 * static_cast<size_t>(F));
    t.face_e.resize(4 * static_cast<size_t>(F));
    t.edge_v.resize(S + static_cast<size_t>(P) * 2 * m * (m - 1));
    t.edge_f.assign(t.edge_v.size(), {-1, -1});
    for (int32_t i = 0; i < E1; ++i) {
        for (int32_t k = 0; k < m; ++k) {
            t.edge_v[i * m + k] = {t.skeleton[i * side + k], t.skeleton[i * side + k + 1]};
        }
    }
    auto add_face = [&](int32_t edge, int32_t face) {
        auto& slot = t.edge_f[edge];
        (slot[0] == -1 ? slot[0] : slot[1]) = face;
    };
    for (int32_t p = 0; p < P; ++p) {
        const int32_t* g = &t.patch_grid[p * side * side];
        for (int32_t r = 0; r < m; ++r) {
            for (int32_t c = 0; c < m; ++c) {
                const int32_t k = p * m * m + r * m + c;
                const int32_t corners[4] = {g[r * side + c], g[r * side + c + 1],
                                            g[(r + 1) * side + c + 1], g[(r + 1) * side + c]};
                const int32_t sides[4] = {
                    horizontal_edge(ps, p, r, c, m), vertical_edge(ps, p, r, c + 1, m),
                    horizontal_edge(ps, p, r + 1, c, m), vertical_edge(ps, p, r, c, m)};
                for (int s = 0; s < 4; ++s) {
                    t.face_v[4 * k + s] = corners[s];
                    t.face_e[4 * k + s] = sides[s];
                    add_face(sides[s], k);
                }
            }
        }
        for (int32_t r = 0; r <= m; ++r) {
            for (int32_t c = 0; c <= m; ++c) {
                if (c < m && r > 0 && r < m) {
                    t.edge_v[horizontal_edge(ps, p, r, c, m)] = {g[r * side + c],
                                                                 g[r * side + c + 1]};
                }
                if (r < m && c > 0 && c < m) {
                    t.edge_v[vertical_edge(ps, p, r, c, m)] = {g[r * side + c],
                                                               g[(r + 1) * side + c]};
                }
                if (r > 0 && r < m && c > 0 && c < m) t.patch_interior[g[r * side + c]] = 1;
            }
        }
    }
}

}  // namespace

LevelTopology refine_patches(const LevelTopology& t, const PatchSides& ps, bool topology) {
    const int32_t m = t.patch_cells, M = 2 * m, P = static_cast<int32_t>(ps.sides.size());
    const int32_t n = t.n_vertices, E = t.num_edges();
    LevelTopology next;
    next.n_vertices = n + E + t.num_faces();
    next.patch_cells = M;
    next.kind.assign(next.n_vertices, PointKind::interior);
    std::copy(t.kind.begin(), t.kind.end(), next.kind.begin());
    for (int32_t i = 0; i < E; ++i) {
        if (t.edge_f[i][1] == -1) next.kind[n + i] = PointKind::curve;
    }
    const size_t side = m + 1, side2 = M + 1;
    next.skeleton.resize(ps.num_t1_edges * side2);
    for (int32_t i = 0; i < ps.num_t1_edges; ++i) {
        for (int32_t k = 0; k <= m; ++k) {
            next.skeleton[i * side2 + 2 * k] = t.skeleton[i * side + k];
            if (k < m) next.skeleton[i * side2 + 2 * k + 1] = n + i * m + k;
        }
    }
    next.patch_grid.resize(P * side2 * side2);
    for (int32_t p = 0; p < P; ++p) {
        const int32_t* g = &t.patch_grid[p * side * side];
        int32_t* h = &next.patch_grid[p * side2 * side2];
        for (int32_t r = 0; r <= m; ++r) {
            for (int32_t c = 0; c <= m; ++c) {
                h[2 * r * side2 + 2 * c] = g[r * side + c];
                if (c < m) h[2 * r * side2 + 2 * c + 1] = n + horizontal_edge(ps, p, r, c, m);
                if (r < m) h[(2 * r + 1) * side2 + 2 * c] = n + vertical_edge(ps, p, r, c, m);
                if (r < m && c < m) {
                    h[(2 * r + 1) * side2 + 2 * c + 1] = n + E + p * m * m + r * m + c;
                }
            }
        }
    }
    next.topology = topology;
    if (!topology) return next;
    next.patch_interior.assign(next.n_vertices, 0);
    topology_from_grids(next, ps);
    return next;
}

}  // namespace tesswave::detail
