// The frame between two frames with nothing but the frames (tesswave inbetween, eval-interp):
// automatic correspondences, a grid mesh on the first frame fitted to them, and a morph.
#pragma once

#include <string>

#include "auto_match.h"
#include "core/math/image.h"
#include "morph.h"
#include "pair.h"

namespace tesswave::morph {

// The defaults come from eval-interp's search on Middlebury and UCF101 (cells of 8 to 24 px,
// 2 to 3.5 samples a pixel), the linear schedule (frames of one scene correspond almost
// everywhere). With the flow fallback and the fast objects, 20 px cells are within 0.06 dB of
// 10 px cells on average (at most 0.31 dB on one sequence) in 0.37 of the time; the density
// changes nothing measurable there.
struct InbetweenOptions {
    double cell = 20;  // grid cell size in pixels of the first frame
    MorphOptions morph = {.density = 3.5, .schedule = {.kind = ScheduleKind::linear}};
    // Where the mesh's warps of the two frames disagree (small fast objects without
    // correspondences, occlusions), take the frame from dense optical flow (DIS, both ways)
    // as far as its warps agree better; needs frames of one size and channel count.
    bool flow_fallback = true;
    // Small objects that move further than the flow sees (a thrown ball): blocks that neither
    // the mesh nor the flow matched are searched for in the other frame, kept where both ways
    // agree, and carried to the moment t; where they were, the other frame shows the ground.
    // Needs flow_fallback.
    bool fast_objects = true;
};

// The meshes of the pair: a cell-sized grid on f0 fitted to automatic correspondences on f1
// (auto_match with flows that stop a pyramid level short of full resolution: frames of one scene
// need no finer ones). `flow` (optional) receives those flows (see AutoMatchOptions::flow).
PairMeshes automatic_pair(const Image& f0, const Image& f1, double cell, DenseFlow* flow = nullptr);

// The same, except that for frames of one size where no mesh fits the correspondences (too few
// of them, or motions no valid mesh follows: a small object moving fast over a plain scene),
// both meshes are the grid at rest and `note` (optional) receives one line that says so.
PairMeshes automatic_pair_or_rest(const Image& f0, const Image& f1, double cell,
                                  std::string* note = nullptr, DenseFlow* flow = nullptr);

// The frame at t: the morph of the automatic pair, then the flow fallback and the fast objects
// of InbetweenOptions. With the flow fallback (frames of one size and channel count, at least 16
// pixels a side), the pair is automatic_pair_or_rest's: at rest, the flow and the fast objects
// make the frame.
Image inbetween(const Image& f0, const Image& f1, double t, const InbetweenOptions& options = {},
                std::string* note = nullptr);

}  // namespace tesswave::morph
