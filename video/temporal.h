// Temporal lifting along the moving mesh (DESIGN.md 4): within a group every frame has the same
// topology, so coefficient i of frame t and of frame t + 1 describe the same material wherever
// the mesh has moved it, and a wavelet along t needs no motion inversion (the paper's trivariate
// transform on a grid that moves with the objects).
//
// The transform is the 5/3 on each coefficient's sequence, in place, as motion-compensated
// temporal filtering runs it. Each level splits the slots it works on into even ones (kept) and
// odd ones, each odd slot m lying between two even ones l < m < r:
//   predict  x_m -= w_l x_l + w_r x_r   (w_l = (r - m) / (r - l), w_r = (m - l) / (r - l): the
//                                        value the neighbours interpolate; the high band is what
//                                        they do not predict)
//   update   x_e += (d_a + d_b) / 4     for each even slot e and the odd slots a, b next to it
// with a missing neighbour mirrored (the one there is taken twice). Slot 0 ends as the group's
// low band, every other slot as a high band. Which slots pair up is the tree:
// - dyadic (.twv version 2 and 3): level l works on the slots at stride 2^l; the odd slots are
//   the odd multiples, and past the group's end a neighbour is mirrored. A group of 2^k + 1
//   frames has every frame but the last between two others on every level; in other lengths the
//   slots past the last power of two are extrapolated from one side (a group of 16: frames 8, 12,
//   14 and 15 from the frames before them only).
// - bisection (version 4): the first and last frames are the top level (the last predicted from
//   the first); below it each span between two even slots is halved at its middle (rounded
//   down), until every slot is reached. Every frame but the last lies between two others at
//   every length; at 2^k + 1 frames it is the dyadic tree.
#pragma once

#include <vector>

#include "core/codec/coding_domain.h"

namespace tesswave::video {

enum class TemporalTree { dyadic, bisection };

// The levels that leave one low band in a group of n frames (0 for n = 1): ceil(log2 n) on the
// dyadic tree, 1 + ceil(log2 (n - 1)) on the bisection tree.
int temporal_levels(int n, TemporalTree tree = TemporalTree::bisection);

// In place over the group's frames (all of one shape); the finest `levels` levels.
void temporal_forward(std::vector<Planes>& frames, int levels,
                      TemporalTree tree = TemporalTree::bisection);
void temporal_inverse(std::vector<Planes>& frames, int levels,
                      TemporalTree tree = TemporalTree::bisection);

// The L2 norm of each slot's synthesis function (the inverse transform of a unit impulse there),
// over n frames: an error e in slot t costs about e^2 norm_t^2 of squared error summed over the
// group, so a step divided by norm_t spends bits alike in every slot.
std::vector<double> temporal_norms(int n, int levels, TemporalTree tree = TemporalTree::bisection);

}  // namespace tesswave::video
