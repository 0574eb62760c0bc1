#include "core/math/hierarchy.h"

#include <algorithm>
#include <numeric>
#include <unordered_set>

#include "core/math/error.h"
#include "core/math/patch_grid.h"
#include "core/math/strings.h"
#include "core/math/validate.h"

namespace tesswave {
namespace {

uint64_t edge_key(int32_t a, int32_t b) {
    return (static_cast<uint64_t>(std::min(a, b)) << 32) | static_cast<uint32_t>(std::max(a, b));
}

int32_t find_root(std::vector<int32_t>& parent, int32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
}

bool is_domain_corner(const Mesh& mesh, Vec2 p) {
    return (p.x == 0 || p.x == mesh.width) && (p.y == 0 || p.y == mesh.height);
}

// Cuts T0 along its feature edges. Corner incidences (face, corner) around one vertex are joined
// across every non-feature interior edge; each resulting sector becomes one sample. The first
// sector keeps the mesh's vertex id, further ones are appended.
LevelTopology cut_mesh(const Mesh& mesh, std::vector<int32_t>& source_vertex) {
    const MeshEdges edges = build_edges(mesh);
    std::unordered_set<uint64_t> feature_set;
    for (auto [a, b] : mesh.features) feature_set.insert(edge_key(a, b));

    // Curve degree: boundary plus feature edges at each mesh vertex decides its point kind.
    std::vector<int> curve_degree(mesh.vertices.size(), 0);
    for (size_t e = 0; e < edges.vertices.size(); ++e) {
        auto [a, b] = edges.vertices[e];
        if (edges.faces[e][1] == -1 || feature_set.count(edge_key(a, b))) {
            ++curve_degree[a];
            ++curve_degree[b];
        }
    }

    const size_t incidences = mesh.face_corners.size();
    std::vector<int32_t> parent(incidences);
    std::iota(parent.begin(), parent.end(), 0);
    // Where each edge sits in each of its faces: incidence index of the edge's first vertex.
    // Faces never repeat a vertex (validated), so a vertex's incidence in a face is unique.
    std::vector<std::array<int32_t, 2>> slot(edges.vertices.size(), {-1, -1});
    for (int32_t f = 0; f < mesh.num_faces(); ++f) {
        const int32_t off = mesh.face_offsets[f], d = mesh.face_offsets[f + 1] - off;
        for (int32_t t = 0; t < d; ++t) {
            const int32_t e = edges.face_edges[off + t];
            const int32_t here = off + t, next = off + (t + 1) % d;
            const int32_t at_first = mesh.face_corners[here] == edges.vertices[e][0] ? here : next;
            (edges.faces[e][0] == f ? slot[e][0] : slot[e][1]) = at_first;
        }
    }
    // The incidence of vertex v in the face holding incidence `i` of edge endpoint 0.
    auto incidence_of = [&](int32_t i, int32_t v) {
        if (mesh.face_corners[i] == v) return i;
        int32_t f = static_cast<int32_t>(
            std::upper_bound(mesh.face_offsets.begin(), mesh.face_offsets.end(), i) -
            mesh.face_offsets.begin() - 1);
        const int32_t off = mesh.face_offsets[f], d = mesh.face_offsets[f + 1] - off;
        const int32_t next = off + (i - off + 1) % d, prev = off + (i - off + d - 1) % d;
        return mesh.face_corners[next] == v ? next : prev;
    };
    for (size_t e = 0; e < edges.vertices.size(); ++e) {
        auto [f, g] = edges.faces[e];
        auto [a, b] = edges.vertices[e];
        if (g == -1 || feature_set.count(edge_key(a, b))) continue;
        for (int32_t v : {a, b}) {
            int32_t r1 = find_root(parent, incidence_of(slot[e][0], v));
            int32_t r2 = find_root(parent, incidence_of(slot[e][1], v));
            if (r1 != r2) parent[std::max(r1, r2)] = std::min(r1, r2);
        }
    }

    LevelTopology t0;
    t0.face_offsets.assign(mesh.face_offsets.begin(), mesh.face_offsets.end());
    t0.face_v.resize(incidences);
    source_vertex.resize(mesh.vertices.size());
    std::iota(source_vertex.begin(), source_vertex.end(), 0);
    std::vector<int32_t> sample_of_root(incidences, -1);
    std::vector<char> vertex_taken(mesh.vertices.size(), 0);
    for (size_t i = 0; i < incidences; ++i) {
        int32_t root = find_root(parent, static_cast<int32_t>(i));
        int32_t v = mesh.face_corners[i];
        if (sample_of_root[root] == -1) {
            if (!vertex_taken[v]) {
                vertex_taken[v] = 1;
                sample_of_root[root] = v;
            } else {
                sample_of_root[root] = static_cast<int32_t>(source_vertex.size());
                source_vertex.push_back(v);
            }
        }
        t0.face_v[i] = sample_of_root[root];
    }
    t0.n_vertices = static_cast<int32_t>(source_vertex.size());
    t0.kind.resize(t0.n_vertices);
    for (int32_t s = 0; s < t0.n_vertices; ++s) {
        int32_t v = source_vertex[s];
        int d = curve_degree[v];
        t0.kind[s] = d == 0                                                ? PointKind::interior
                     : d == 2 && !is_domain_corner(mesh, mesh.vertices[v]) ? PointKind::curve
                                                                           : PointKind::corner;
    }

    // Edges of the cut mesh: a feature edge becomes two boundary edges, one per side.
    Mesh cut;
    cut.face_offsets = mesh.face_offsets;
    cut.face_corners.assign(t0.face_v.begin(), t0.face_v.end());
    const MeshEdges cut_edges = build_edges(cut);
    t0.edge_v.assign(cut_edges.vertices.begin(), cut_edges.vertices.end());
    t0.edge_f.assign(cut_edges.faces.begin(), cut_edges.faces.end());
    t0.face_e.assign(cut_edges.face_edges.begin(), cut_edges.face_edges.end());
    return t0;
}

// T_j -> T_{j+1}: edge i = (a,b) splits into 2i = (a, m_i) and 2i+1 = (m_i, b); face k with d
// corners adds spokes 2E + off_k + t = (m(e_t), centroid_k) and the quads
// off_k + t = (c_t, m(e_t), centroid_k, m(e_{t-1})).
LevelTopology refine(const LevelTopology& t) {
    const int32_t n = t.n_vertices, E = t.num_edges(), F = t.num_faces();
    const int32_t S = static_cast<int32_t>(t.face_v.size());
    LevelTopology next;
    next.n_vertices = n + E + F;
    next.kind.resize(next.n_vertices, PointKind::interior);
    std::copy(t.kind.begin(), t.kind.end(), next.kind.begin());
    next.edge_v.resize(2 * E + S);
    next.edge_f.assign(2 * E + S, {-1, -1});
    for (int32_t i = 0; i < E; ++i) {
        auto [a, b] = t.edge_v[i];
        next.edge_v[2 * i] = {a, n + i};
        next.edge_v[2 * i + 1] = {n + i, b};
        if (t.edge_f[i][1] == -1) next.kind[n + i] = PointKind::curve;
    }
    next.face_offsets.resize(S + 1);
    for (int32_t q = 0; q <= S; ++q) next.face_offsets[q] = 4 * q;
    next.face_v.resize(4 * S);
    next.face_e.resize(4 * S);
    auto add_face_to_edge = [&](int32_t edge, int32_t face) {
        auto& slot = next.edge_f[edge];
        (slot[0] == -1 ? slot[0] : slot[1]) = face;
    };
    auto half_at = [&](int32_t edge, int32_t corner) {
        return t.edge_v[edge][0] == corner ? 2 * edge : 2 * edge + 1;
    };
    for (int32_t k = 0; k < F; ++k) {
        const int32_t off = t.face_offsets[k], d = t.face_offsets[k + 1] - off;
        const int32_t centroid = n + E + k;
        for (int32_t s = 0; s < d; ++s) {
            next.edge_v[2 * E + off + s] = {n + t.face_e[off + s], centroid};
            next.edge_f[2 * E + off + s] = {off + s, off + (s + 1) % d};
        }
        for (int32_t s = 0; s < d; ++s) {
            const int32_t prev = (s + d - 1) % d, q = off + s, c = t.face_v[off + s];
            const int32_t e_here = t.face_e[off + s], e_prev = t.face_e[off + prev];
            const int32_t corners[4] = {c, n + e_here, centroid, n + e_prev};
            const int32_t sides[4] = {half_at(e_here, c), 2 * E + off + s, 2 * E + off + prev,
                                      half_at(e_prev, c)};
            for (int r = 0; r < 4; ++r) {
                next.face_v[4 * q + r] = corners[r];
                next.face_e[4 * q + r] = sides[r];
            }
            add_face_to_edge(sides[0], q);
            add_face_to_edge(sides[3], q);
        }
    }
    return next;
}

void build_stars(LevelTopology& t) {
    const int32_t n = t.n_vertices;
    t.star_e_offsets.assign(n + 1, 0);
    t.star_f_offsets.assign(n + 1, 0);
    for (auto [a, b] : t.edge_v) ++t.star_e_offsets[a + 1], ++t.star_e_offsets[b + 1];
    for (int32_t v : t.face_v) ++t.star_f_offsets[v + 1];
    std::partial_sum(t.star_e_offsets.begin(), t.star_e_offsets.end(), t.star_e_offsets.begin());
    std::partial_sum(t.star_f_offsets.begin(), t.star_f_offsets.end(), t.star_f_offsets.begin());
    t.star_e.resize(t.star_e_offsets[n]);
    t.star_f.resize(t.star_f_offsets[n]);
    std::vector<int32_t> fill(t.star_e_offsets.begin(), t.star_e_offsets.end() - 1);
    t.curve_e.assign(n, {-1, -1});
    for (int32_t i = 0; i < t.num_edges(); ++i) {
        for (int32_t v : t.edge_v[i]) {
            t.star_e[fill[v]++] = i;
            if (t.edge_f[i][1] == -1)
                (t.curve_e[v][0] == -1 ? t.curve_e[v][0] : t.curve_e[v][1]) = i;
        }
    }
    fill.assign(t.star_f_offsets.begin(), t.star_f_offsets.end() - 1);
    for (int32_t k = 0; k < t.num_faces(); ++k) {
        for (int32_t c = t.face_offsets[k]; c < t.face_offsets[k + 1]; ++c) {
            t.star_f[fill[t.face_v[c]]++] = k;
        }
    }
    const int32_t E = t.num_edges();
    // Vertices strictly inside a patch (levels with m >= 2) are left to the patch kernel.
    for (int32_t v = 0; v < n; ++v) {
        if (t.kind[v] == PointKind::curve) {
            t.v_curve.push_back(v);
        } else if (t.kind[v] == PointKind::interior &&
                   (t.patch_interior.empty() || t.patch_cells < 2 || !t.patch_interior[v])) {
            const int32_t e0 = t.star_e_offsets[v], f0 = t.star_f_offsets[v];
            if (t.star_e_offsets[v + 1] - e0 == 4 && t.star_f_offsets[v + 1] - f0 == 4) {
                t.v_regular.push_back(v);
                std::array<int32_t, 8> nb;
                for (int r = 0; r < 4; ++r) {
                    nb[r] = n + t.star_e[e0 + r];
                    nb[4 + r] = n + E + t.star_f[f0 + r];
                }
                t.v_regular_nb.push_back(nb);
            } else {
                t.v_irregular.push_back(v);
            }
        }
    }
    // The regular vertices in the order of their first face, not of their ids: along a T1 edge
    // the ids jump between the levels that made the vertices, and its vertices' faces and edges
    // lie a patch row apart, so in id order every read missed the cache; in face order the reads
    // ascend through each patch, which the prefetchers follow (the transform at 10^7 samples
    // spent 38 % of its time here). Each vertex's update reads only edges and faces, so the order
    // does not change a bit.
    std::vector<int32_t> order(t.v_regular.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](int32_t a, int32_t b) {
        return t.v_regular_nb[a][4] < t.v_regular_nb[b][4];
    });
    HugeVector<int32_t> vertices(order.size());
    HugeVector<std::array<int32_t, 8>> neighbours(order.size());
    for (size_t i = 0; i < order.size(); ++i) {
        vertices[i] = t.v_regular[order[i]];
        neighbours[i] = t.v_regular_nb[order[i]];
    }
    t.v_regular = std::move(vertices);
    t.v_regular_nb = std::move(neighbours);
}

struct RawCounts {
    int64_t vertices, edges, faces, corner_sum, boundary_edges;
};

std::vector<RawCounts> recurrence(RawCounts c, int levels) {
    if (levels < 0 || levels > 40) throw Error(str("levels: ", levels, " is outside 0..40"));
    std::vector<RawCounts> out{c};
    for (int j = 0; j < levels; ++j) {
        // Every count at most quadruples a level; refuse before 64 bits overflow.
        if (c.vertices + c.edges + c.faces > (int64_t{1} << 60) ||
            c.corner_sum > (int64_t{1} << 60)) {
            throw Error(
                str("level ", j + 1, ": more than 2^62 vertices or edges; pick a lower level"));
        }
        c = {c.vertices + c.edges + c.faces, 2 * c.edges + c.corner_sum, c.corner_sum,
             4 * c.corner_sum, 2 * c.boundary_edges};
        out.push_back(c);
    }
    return out;
}

}  // namespace

std::vector<LevelCounts> level_counts(const Mesh& mesh, int levels) {
    const MeshEdges edges = build_edges(mesh);
    int64_t boundary = 0;
    for (auto f : edges.faces) boundary += f[1] == -1;
    auto raw =
        recurrence({mesh.num_vertices(), static_cast<int64_t>(edges.vertices.size()),
                    mesh.num_faces(), static_cast<int64_t>(mesh.face_corners.size()), boundary},
                   levels);
    std::vector<LevelCounts> out;
    for (int j = 0; j <= levels; ++j) {
        out.push_back({j, raw[j].vertices, raw[j].edges, raw[j].faces, raw[j].boundary_edges});
    }
    return out;
}

int64_t sample_count(const Mesh& mesh, int levels) {
    std::vector<int32_t> source;
    LevelTopology t0 = cut_mesh(mesh, source);
    int64_t boundary = 0;
    for (auto f : t0.edge_f) boundary += f[1] == -1;
    return recurrence({t0.n_vertices, t0.num_edges(), t0.num_faces(),
                       static_cast<int64_t>(t0.face_v.size()), boundary},
                      levels)
        .back()
        .vertices;
}

int64_t hierarchy_bytes(int64_t samples) {
    // Measured peak while building (all levels, stars, fast-path tables and patch grids): about
    // 180-190 bytes per finest-level sample on Voronoi meshes of 6e5 and 1e7 samples.
    return samples * 192;
}

Hierarchy build_hierarchy(const Mesh& mesh, const HierarchyOptions& options) {
    require_valid(mesh, "mesh");
    if (options.levels < 0 || options.levels > 16) {
        throw Error(str("levels: ", options.levels, " is outside the supported range 0..16"));
    }
    const int64_t samples = sample_count(mesh, options.levels);
    if (samples > options.max_samples || samples >= (int64_t{1} << 31)) {
        throw Error(str("level ", options.levels, " needs ", samples, " samples (about ",
                        hierarchy_bytes(samples) >> 20,
                        " MiB for the hierarchy alone); the limit "
                        "is ",
                        options.max_samples, " samples"));
    }
    Hierarchy h;
    h.levels.push_back(cut_mesh(mesh, h.source_vertex));
    if (options.levels >= 1) {
        h.levels.push_back(refine(h.levels.back()));
        const detail::PatchSides sides = detail::patch_sides(h.levels[1]);
        detail::init_patch_grids(h.levels[1], sides);
        for (int j = 1; j < options.levels; ++j) {
            const bool topology = options.finest_topology || j + 1 < options.levels;
            h.levels.push_back(detail::refine_patches(h.levels.back(), sides, topology));
        }
    }
    for (auto& level : h.levels) {
        if (level.topology) build_stars(level);
    }
    return h;
}

std::vector<Vec2> refine_positions(const Hierarchy& hierarchy, std::span<const Vec2> mesh_vertices,
                                   int level) {
    std::vector<Vec2> p(hierarchy.num_samples(level));
    for (size_t s = 0; s < hierarchy.source_vertex.size(); ++s) {
        p[s] = mesh_vertices[hierarchy.source_vertex[s]];
    }
    for (int j = 0; j < level; ++j) {
        const LevelTopology& t = hierarchy.levels[j];
        const int32_t n = t.n_vertices, E = t.num_edges();
        for (int32_t i = 0; i < E; ++i) p[n + i] = 0.5 * (p[t.edge_v[i][0]] + p[t.edge_v[i][1]]);
        for (int32_t k = 0; k < t.num_faces(); ++k) {
            Vec2 sum{};
            for (int32_t c = t.face_offsets[k]; c < t.face_offsets[k + 1]; ++c) {
                sum = sum + p[t.face_v[c]];
            }
            p[n + E + k] = (1.0 / (t.face_offsets[k + 1] - t.face_offsets[k])) * sum;
        }
    }
    return p;
}

}  // namespace tesswave
