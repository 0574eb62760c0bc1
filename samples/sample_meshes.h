// Procedural sample tessellations the project generates itself (no external data).
#pragma once

#include "core/math/mesh.h"

namespace tesswave::samples {

// A tessellation like the paper's Figure 7 setup: 20 vertices, 14 convex faces (quads and
// triangles, one interior vertex of valence 3), 33 edges of which 13 lie on the border, so that
// q = 53 and |V_7| = 217921. Built from a deformed 4x3 grid with one top-border vertex pulled
// inside and one cell split along a diagonal.
Mesh paper_t0(double width, double height);

// paper_t0 with a feature curve 5-6-7-8 of three edges, from the left border to an interior end
// (for tests and demos of the double set of coefficients along features).
Mesh paper_t0_with_features(double width, double height);

}  // namespace tesswave::samples
