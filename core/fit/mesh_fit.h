// Fitting a tessellation to point correspondences (DESIGN.md 3 and 4): given a valid mesh on image
// A and matches a_k -> b_k, find the positions x of the same mesh on image B. Each a_k is pinned
// to its parametric location (face, T1 quad, u, v) on A; under positions x it lands at P_k x, the
// bilinear map (parametrization.h, equation 2.2) of that T1 quad, whose corners (a vertex, two
// edge midpoints and the face's vertex average) are linear in the face's corners. With r the
// vertices of A scaled to B's domain, fit_mesh minimises over x and one S_f per face
//
//   E =       sum_k rho(|P_k x - b_k|^2)                                        data
//     + w_r sum_f sum_(i,j) (l / |r_ij|)^2 |x_ij - S_f r_ij|^2                  rigidity
//     + w_s sum_i |L(x - r)_i|^2                                                smoothness
//     + w_t sum_i |x_i - x_i^prev|^2                                            temporal
//     + w_c sum_corners beta(sin theta, m)^2 + w_c sum_(i,j) beta(|x_ij| / |r_ij|, e)^2   barriers
//
// - rho(s) = c^2 log(1 + s / c^2), the Cauchy loss with c = robust_scale;
// - x_ij = x_j - x_i over the edges (i, j) of face f, r_ij likewise, l the mean edge length of r:
//   the rigidity term measures strain, so short edges are as stiff as long ones; S_f is a
//   rotation (as-rigid-as-possible) or a rotation and scale (as-similar-as-possible);
// - L is the umbrella Laplacian over the mesh edges (a vertex minus the mean of its neighbours);
// - beta(q, m) = (m - q) / q for q < m and 0 above, w_c = 10; sin theta = (e_in x e_out) /
//   (|e_in| |e_out|) at every face corner with m = min(min_corner_sine, half its sine in r), so
//   that corners already sharp in A are not pushed; e = min_edge_ratio keeps edges from
//   collapsing. A step that makes any corner reflex or any edge vanish is rejected, so every
//   iterate keeps every face convex.
// Border vertices slide along their side of [0,W_B]x[0,H_B] (the coordinate across it is held
// exactly), and the four domain corners stay fixed.
//
// Solved with Ceres (Levenberg-Marquardt, sparse normal Cholesky, one thread, silent), starting
// from the previous frame's vertices when given, else from a robust affine fit of the
// correspondences applied to r, else (when neither is a valid mesh) from r.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/math/geometry.h"
#include "core/math/mesh.h"
#include "core/math/progress.h"

namespace tesswave {

// A parametric location on a mesh: T1 quad `quad` (numbered as in hierarchy.h and t1_quads():
// mesh.face_offsets[face] + corner, the quad at that corner of `face`), coordinates (u, v) in it.
struct PinnedPoint {
    int32_t face = -1;
    int32_t quad = -1;
    double u = 0.0, v = 0.0;
};

// Locates each point on the T1 quads of a valid mesh (Error otherwise); nullopt for a point
// outside the domain or not finite.
std::vector<std::optional<PinnedPoint>> pin_points(const Mesh& mesh, std::span<const Vec2> points);
// The same with the mesh's topology at `positions` (one per vertex): no copy of the topology.
std::vector<std::optional<PinnedPoint>> pin_points(const Mesh& mesh,
                                                   std::span<const Vec2> positions,
                                                   std::span<const Vec2> points);

// Where a pinned point lands when the mesh's vertices move to `vertices` (one per mesh vertex).
// Throws Error for a pin that does not name a T1 quad of the mesh.
Vec2 pinned_position(const Mesh& mesh, std::span<const Vec2> vertices, const PinnedPoint& pin);

enum class Rigidity { as_rigid, as_similar };

struct MeshFitOptions {
    Rigidity rigidity = Rigidity::as_similar;
    // Weights against one correspondence's squared px. The defaults let ~6 matches per face
    // follow a 4 px sinusoid on 40 px cells to 0.3 px; rigidity_weight = 1 would hold it to 0.7.
    double rigidity_weight = 0.1;    // w_r
    double smoothness_weight = 0.1;  // w_s
    double robust_scale = 3.0;       // c of the Cauchy loss, px
    double outlier_factor = 3.0;     // a match left farther than this x robust_scale is an outlier
    double min_corner_sine = 0.05;   // convexity margin m (about 3 degrees from straight)
    double min_edge_ratio = 0.05;    // collapse margin: an edge keeps 1/20 of its length in r
    int max_iterations = 100;
    // Stop once a successful step moves the vertices by less than this, px (the norm over all of
    // them); 0: run to the solver's own tolerances. The fit creeps for tens of steps of a few
    // hundredths of a pixel where the Cauchy loss and the barriers meet; a caller that rounds the
    // result (video motion is coded in quarter pixels) need not wait for them.
    double step_tolerance = 0.0;
    // Optional (video): the previous frame's vertices on B, the start of the fit when they form a
    // valid mesh there, and the target of the temporal term.
    std::span<const Vec2> previous = {};
    double temporal_weight = 0.0;  // w_t; needs `previous`
    Progress progress = {};        // optional
};

struct MeshFitResult {
    // Non-empty when no valid mesh fits ("no valid mesh fits: ..." with the first broken rule or
    // too few inliers): an expected outcome, not an error; vertices is then empty.
    std::string failure;
    bool ok() const { return failure.empty(); }
    std::vector<Vec2> vertices;     // on B, a valid mesh with mesh A's faces on [0,W_B]x[0,H_B]
    std::vector<double> residuals;  // per correspondence: |P_k x - b_k| after the fit, px
    double rms = 0, max = 0;        // over the inliers, px
    int inliers = 0, outliers = 0;
    int iterations = 0;
};

// Throws Error for bad input (an invalid mesh A, a point of A outside A's domain, non-finite
// points, mismatched counts, fewer than 3 matches, bad options). When the fit is not a valid
// mesh or keeps fewer than 3 inliers, the result says so in `failure`.
MeshFitResult fit_mesh(const Mesh& mesh_a, std::span<const Vec2> points_a,
                       std::span<const Vec2> points_b, double width_b, double height_b,
                       const MeshFitOptions& options = {});

}  // namespace tesswave
