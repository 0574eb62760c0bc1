// The frame between two frames with nothing but the frames (tesswave inbetween, eval-interp):
// automatic correspondences, a grid mesh on the first frame fitted to them, and a morph.
#pragma once

#include "core/math/image.h"
#include "morph.h"
#include "pair.h"

namespace tesswave::morph {

struct InbetweenOptions {
    double cell = 24;  // grid cell size in pixels of the first frame
    MorphOptions morph = {};
};

// The meshes of the pair: a cell-sized grid on f0 fitted to automatic correspondences on f1.
PairMeshes automatic_pair(const Image& f0, const Image& f1, double cell = 24);

Image inbetween(const Image& f0, const Image& f1, double t, const InbetweenOptions& options = {});

}  // namespace tesswave::morph
