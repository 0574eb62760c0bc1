// Temporal lifting along the moving mesh (DESIGN.md 4): within a group every frame has the same
// topology, so coefficient i of frame t and of frame t + 1 describe the same material wherever
// the mesh has moved it, and a wavelet along t needs no motion inversion (the paper's trivariate
// transform on a grid that moves with the objects).
//
// The transform is the 5/3 on each coefficient's sequence, dyadic and in place, as motion-
// compensated temporal filtering runs it. Level l works on the slots at stride s = 2^l; with
// x_j the slot j s:
//   predict  x_j -= (x_{j-1} + x_{j+1}) / 2   for odd j   (the high band: what the neighbours
//                                                          do not predict)
//   update   x_j += (x_{j-1} + x_{j+1}) / 4   for even j  (the low band: a smoothed frame)
// with a missing neighbour mirrored (x_{j+1} := x_{j-1} at the end of the group). Slot 0 ends as
// the group's low band; slot t (t > 0) holds a high band of level log2 of t's lowest set bit.
// Any group length works; levels = temporal_levels(n) leaves one low band.
#pragma once

#include <vector>

#include "core/codec/coding_domain.h"

namespace tesswave::video {

// ceil(log2 n): the levels that leave one low band in a group of n frames (0 for n = 1).
int temporal_levels(int n);

// In place over the group's frames (all of one shape).
void temporal_forward(std::vector<Planes>& frames, int levels);
void temporal_inverse(std::vector<Planes>& frames, int levels);

// The L2 norm of each slot's synthesis function (the inverse transform of a unit impulse there),
// over n frames: an error e in slot t costs about e^2 norm_t^2 of squared error summed over the
// group, so a step divided by norm_t spends bits alike in every slot.
std::vector<double> temporal_norms(int n, int levels);

}  // namespace tesswave::video
