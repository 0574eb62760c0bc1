// Automatic correspondences between two images (DESIGN.md 3, "automatic ones"): dense optical
// flow (OpenCV DIS) both ways with a forward-backward check, plus sparse feature matches (ORB,
// ratio test) whose RANSAC similarity is the prior that brings large motions within the flow's
// reach.
//
// B's working copy is B in grey, resized to A's size (S scales back) and pre-warped by the prior
// T, so the flow u (A -> warped copy) and v (back) only find the residual. A grid sample x of A
//   b = S T(x + u(x))   is kept when   |x - (y + v(y))| < fb_tolerance  at y = x + u(x),
// b lies in B, A is textured at x (flat ground and straight edges let any flow pass the check)
// and A's window at x correlates with the copy's under the flow's local affine map.
// A feature match is kept where it agrees with that field within ransac_px, at the field's
// point; elsewhere where it agrees with T, refined by Lucas-Kanade and correlated the same way.
#pragma once

#include <functional>
#include <vector>

#include "core/math/geometry.h"
#include "core/math/image.h"
#include "core/math/progress.h"

namespace tesswave::morph {

// Dense flows between two images of one size, per pixel, row-major (dx, dy) pairs.
struct DenseFlow {
    int width = 0, height = 0;    // 0: no flows
    std::vector<float> forward;   // per pixel of A: where it is in B, relative
    std::vector<float> backward;  // per pixel of B: where it is in A, relative
};

struct AutoMatchOptions {
    int grid_step = 8;          // flow samples every grid_step pixels of A
    double fb_tolerance = 1.0;  // forward-backward distance (pixels of A) a sample may have
    bool features = true;       // ORB matches: the prior and extra matches
    double ratio = 0.75;        // Lowe's ratio test, best / second-best descriptor distance
    double ransac_px = 3.0;     // inlier distance of a feature match (pixels of A)
    int max_points = 4000;      // more matches are thinned evenly to this many
    // The smaller eigenvalue of A's structure tensor (9x9 mean, grey in [0,1] per pixel) a
    // match needs: 1e-5 is a gradient of about 1/300 in the weakest direction.
    double min_texture = 1e-5;
    // The zero-mean normalized cross-correlation of 9x9 windows a match needs.
    double min_similarity = 0.5;
    Progress progress = {};  // optional
    // Optional: receives the dense flows when A and B have one size and needed no prior (the
    // flows are then between the images themselves); left empty otherwise. The forward flow runs
    // to full resolution, the backward one stops a pyramid level short.
    DenseFlow* flow = nullptr;
    // The forward flow to full resolution (one pyramid level past DIS's MEDIUM preset, half its
    // error on the tests); false stops it a level short, as the backward one, at a third of the
    // cost.
    bool full_resolution = true;
};

struct Matches {
    std::vector<Vec2> a, b;       // a[i] in A corresponds to b[i] in B, each in its own pixels
    int from_flow = 0;            // kept matches from the dense flow
    int from_features = 0;        // kept matches from features
    int rejected_texture = 0;     // flow samples on flat ground or along straight edges
    int rejected_fb = 0;          // flow samples failing the forward-backward check or leaving B
    int rejected_similarity = 0;  // flow samples whose windows do not correlate
    int rejected_ransac = 0;      // feature matches (after the ratio test) off the field or prior
};

// Correspondences from a to b, which may differ in size and channels. Points use the
// pixel-centre convention of DESIGN.md 2.1 (pixel (i,j) spans [i,i+1)x[j,j+1)); no two kept
// matches lie within 1 pixel of each other in A or in B. Unrelated images give a handful of
// matches (about 1% of the grid) or, when none survives, Error; so do images under 16 pixels a
// side and bad options.
Matches auto_match(const Image& a, const Image& b, const AutoMatchOptions& options = {});

}  // namespace tesswave::morph
