// The classic morph as a peer (learnopencv's FaceMorph and every landmark morpher since
// Beier-Neely's successors): each triangle of the in-between shape takes its affine map to the
// same triangle in A and in B, both images are warped through it (bilinear, one cv::remap each)
// and cross-dissolved. And the measures of a morph's middle frame that compare-morph reports.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/math/image.h"
#include "core/math/mesh.h"

namespace tesswave {

class ClassicMorph {
  public:
    // mesh_a on A's pixel rectangle, mesh_b on B's, one topology (faces are fanned into
    // triangles). Frames are A's size; B's vertices are scaled to it. Throws Error otherwise.
    ClassicMorph(const Image& a, const Image& b, const Mesh& mesh_a, const Mesh& mesh_b);

    // (1 - t) warped A + t warped B on the shape (1 - t) A + t B: the classic warp and dissolve.
    Image frame(double t) const;
    // One image alone (side 0: A, 1: B) warped to the shape at t.
    Image warped(double t, int side) const;

  private:
    void maps(double t, std::vector<float>& xa, std::vector<float>& ya, std::vector<float>& xb,
              std::vector<float>& yb) const;
    Image a_, b_;
    std::vector<Vec2> va_, vb_;  // vertices in A's pixels and in B's pixels
    double sx_ = 1, sy_ = 1;     // B's pixels to A's
    std::vector<std::array<int32_t, 3>> triangles_;
};

// How a middle frame M keeps detail and avoids ghosts, against the two endpoints warped to its
// shape (WA, WB). Detail is each image minus its 5x5 box blur, over channels; over 9x9 windows,
// c = max(0, corr(DA, DB)) says how much the endpoints' detail corresponds there.
struct MorphMeasures {
    double detail = 0;  // sum |DM|^2 / mean of sum |DA|^2 and sum |DB|^2
    double kept = 0;    // the same where the endpoints correspond (c >= 1/2)
    // sum (1 - c) (<DM,DA>^2/|DA|^2 + <DM,DB>^2/|DB|^2) / the endpoints' mean detail energy: the
    // energy of M's detail that matches only one endpoint. Where nothing corresponds, a dissolve
    // scores 1/2, a frame that leaves such detail out 0, one that keeps both in full 2.
    double ghost = 0;
};

MorphMeasures measure_middle(const Image& middle, const Image& warped_a, const Image& warped_b);

}  // namespace tesswave
