// The pair's meshes (DESIGN.md 3): two meshes of one topology, one on each image, from
// corresponding points. Correspondence files are `x y` lines (the format face-landmark tools
// write) or a JSON list, in each image's own pixels, same order in both; an optional triangle
// file has `i j k` lines of point indices.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "core/math/mesh.h"

namespace tesswave::morph {

struct Correspondences {
    std::vector<Vec2> a, b;
};

// Checks a pair of point lists against their images' sizes: equal counts, at least 3, finite,
// inside [0,W]x[0,H], no duplicates within an image. Error names the file and the point.
void check_correspondences(const Correspondences& c, double width_a, double height_a,
                           double width_b, double height_b, const std::string& name_a,
                           const std::string& name_b);

// Points within one pixel of the far border (x >= W - 1, y >= H - 1) are moved onto it: landmark
// tools write border points as the last pixel's index (599 in a 600-pixel image), and the border
// must map to the border. Returns how many moved.
int snap_to_border(std::vector<Vec2>& points, double width, double height);

// `i j k` lines (# comments), indices into a list of `points` points. Error names the line.
std::vector<std::array<int32_t, 3>> parse_triangles(const std::string& text, int points,
                                                    const std::string& name);

struct PairMeshes {
    Mesh a, b;
    std::string description;
    // Points left out to make the meshes valid (0-based indices into the correspondences, in
    // increasing order), and one line that says which and why; empty when none were.
    std::vector<int> dropped = {};
    std::string repair = {};
};

// The classic morph's triangulation: Delaunay of the mean shape (A's points and B's points scaled
// to A's size, averaged) plus the domain corners and `border_points` points a side, the same
// triangles on A's and on B's points (the border points scaled to each image's border). Where a
// triangle still folds in A or in B (the correspondences cross there), the landmark in the most
// folded triangles is dropped and the mean shape triangulated again, until none folds; so is a
// point on the border in one image only, or one that lands on another in the mean shape.
// Error only when fewer than 3 points would remain.
PairMeshes triangulated_pair(const Correspondences& c, double width_a, double height_a,
                             double width_b, double height_b, int border_points = 3);

// The given triangles over the points as they are (they must tile each image: include points on
// the corners and the border). Triangles of zero area in A (three points along the border) are
// dropped. Error names the rule the mesh breaks in A or in B.
PairMeshes triangles_pair(const Correspondences& c, const std::vector<std::array<int32_t, 3>>& t,
                          double width_a, double height_a, double width_b, double height_b);

// A mesh on A (grid or Voronoi, any valid tessellation of A's rectangle) fitted to the
// correspondences on B with Ceres (core/mesh_fit.h). Error when no valid mesh fits.
PairMeshes fitted_pair(const Mesh& mesh_a, const Correspondences& c, double width_b,
                       double height_b);

// No motion: `mesh_a` on A and the same mesh scaled to B's size, for images between which no
// correspondences were found (the morph is then a dissolve on the band schedule).
PairMeshes rest_pair(const Mesh& mesh_a, double width_b, double height_b);

}  // namespace tesswave::morph
