// The refinement hierarchy T_0, T_1, ..., T_J (DESIGN.md 2.2) with nested numbering: the
// vertices of T_j are the first n_j vertices of T_{j+1}, followed by one midpoint per edge of T_j
// and one vertex-average centroid per face of T_j. Topology only; positions live apart
// (refine_positions), so one hierarchy serves many vertex-position sets.
//
// Feature edges are handled by cutting T0 along them: a vertex on a feature curve gets one sample
// per side (the paper's "double set of coefficients"), so feature sides become boundary curves of
// the cut mesh and take the 1D rules, ignoring the other side.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "core/math/huge_buffer.h"
#include "core/math/mesh.h"

namespace tesswave {

enum class PointKind : uint8_t {
    interior,  // 2D lifting rules
    curve,     // on a boundary or feature curve that continues smoothly: 1D rules
    corner,    // domain corner, end or junction of curves: never modified
};

// The topology of one level T_j, with the tables the lifting step T_{j+1} -> T_j reads. Ids are
// vertex ids of T_j; at level j+1 the midpoint of edge i is sample n_vertices + i and the centroid
// of face k is sample n_vertices + num_edges() + k.
struct LevelTopology {
    int32_t n_vertices = 0;
    HugeVector<int32_t> face_offsets;           // CSR; corners of face k: [face_offsets[k], [k+1])
    HugeVector<int32_t> face_v;                 // corners, in the orientation of the mesh
    HugeVector<int32_t> face_e;                 // edge from corner t to corner t+1
    HugeVector<std::array<int32_t, 2>> edge_v;  // endpoints
    HugeVector<std::array<int32_t, 2>> edge_f;  // faces; edge_f[i][1] == -1 on a curve
    HugeVector<PointKind> kind;                 // per vertex
    // Vertex stars (CSR over vertices): incident edges and incident faces.
    HugeVector<int32_t> star_e_offsets, star_e, star_f_offsets, star_f;
    HugeVector<std::array<int32_t, 2>> curve_e;  // per vertex: its two curve edges (curve kind)
    // The vertices of each kind, for the fast lifting kernel: regular interior vertices (4 edges,
    // 4 faces) with their neighbours as sample ids of level j+1 (4 e then 4 f, in star order),
    // the other interior vertices, and the curve vertices. Corners appear in none.
    HugeVector<int32_t> v_regular, v_irregular, v_curve;
    HugeVector<std::array<int32_t, 8>> v_regular_nb;
    // From T1 on, T_j is P patches (the T1 quads) of m x m cells, m = 2^(j-1). Its edges and faces
    // are numbered patch by patch, row by row, so inside a patch they form regular grids:
    //   faces:  p m^2 + r m + c, corners (r,c) (r,c+1) (r+1,c+1) (r+1,c), edges bottom, right,
    //           top, left;
    //   edges:  first the skeleton (the T1 edges): segment k of T1 edge i is i m + k, counted from
    //           its first endpoint; then per patch the m(m-1) interior horizontal edges
    //           (r,c)-(r,c+1), 0<r<m, and the m(m-1) interior vertical ones (r,c)-(r+1,c), 0<c<m.
    // Grid row r = 0 is the T1 quad's p00-p10 side (v = 0), column c = 0 its p00-p01 side (u = 0).
    int32_t patch_cells = 0;          // m; 0 on T0
    HugeVector<int32_t> patch_grid;   // P (m+1)^2 vertex ids, patch-major, row-major
    HugeVector<int32_t> skeleton;     // per T1 edge, its m+1 vertex ids from its first endpoint
    HugeVector<char> patch_interior;  // per vertex: strictly inside a patch, off the skeleton

    // False on the finest level of a hierarchy built without finest_topology: only n_vertices,
    // kind, patch_cells, patch_grid and skeleton are filled (what sampling and rendering read).
    bool topology = true;

    int32_t num_edges() const { return static_cast<int32_t>(edge_v.size()); }
    int32_t num_faces() const { return static_cast<int32_t>(face_offsets.size()) - 1; }
    int32_t n_next() const { return n_vertices + num_edges() + num_faces(); }
};

struct LevelCounts {
    int level = 0;
    int64_t vertices = 0, edges = 0, faces = 0, boundary_edges = 0;
};

struct HierarchyOptions {
    int levels = 5;                    // J
    int64_t max_samples = 50'000'000;  // ~9 GiB of tables; larger ones are refused up front
    // False: T_J (J >= 2) gets no edges, faces or stars. The transform, sampling, projection,
    // rendering and the coding layout never read them, and they are three quarters of the
    // hierarchy's memory and build time; drawing T_J's edges or checking its faces needs them.
    bool finest_topology = true;
};

struct Hierarchy {
    std::vector<LevelTopology> levels;   // T_0 .. T_J (T_0 is the cut mesh)
    std::vector<int32_t> source_vertex;  // per cut-mesh T0 vertex: the mesh vertex it copies

    int finest() const { return static_cast<int>(levels.size()) - 1; }
    int32_t num_samples(int level) const { return levels[level].n_vertices; }
};

// Counts of T_0..T_J of the mesh itself (no feature duplication) by the recurrence of DESIGN.md
// 2.2, without building anything. For j >= 1 they satisfy |V_j| = 1 + q 4^(j-1) + B 2^(j-1).
std::vector<LevelCounts> level_counts(const Mesh& mesh, int levels);

// Number of samples of T_J including feature duplicates, without building anything.
int64_t sample_count(const Mesh& mesh, int levels);

// Approximate bytes build_hierarchy() allocates for a given finest sample count.
int64_t hierarchy_bytes(int64_t samples);

// Builds the hierarchy of a valid mesh (throws Error for an invalid mesh or when the sample count
// exceeds options.max_samples, naming the count and memory it would need).
Hierarchy build_hierarchy(const Mesh& mesh, const HierarchyOptions& options);

// Vertex positions of level `level` (sample order), refined from the T0 mesh vertex positions.
std::vector<Vec2> refine_positions(const Hierarchy& hierarchy, std::span<const Vec2> mesh_vertices,
                                   int level);

}  // namespace tesswave
