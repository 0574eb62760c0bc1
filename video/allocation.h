// Rate–distortion allocation across a group's embedded streams (as JPEG 2000's PCRD across
// code-blocks). Every stream is the bit-plane coder's output for one temporal band, quantized with
// steps that already weigh each coefficient by its synthesis norm (spatial and temporal), so one
// pass of one sweep lowers the squared error per byte alike in every stream: the truncation
// points ordered by (sweep from the top, pass) are ordered by slope. One slope for the group is
// then one point in that order; the budget's remainder is spread over the streams' next pass in
// proportion to its bytes there, so the cuts add up to the budget exactly.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace tesswave::video {

struct EmbeddedStream {
    size_t size = 0;                // the whole stream, as coded (perhaps stopped at a cap)
    std::vector<size_t> pass_ends;  // BitplaneOptions::pass_ends (SIZE_MAX: not reached)
};

struct CutPoint {
    std::vector<size_t> bytes;  // to keep of each stream
    int sweep = 0;              // the sweep (bit-plane from the bottom) the cut falls in
};

// The bytes to keep of each stream so that their sum is at most `budget` (every stream whole
// when that fits). A stream stopped by a cap counts as unreachable past its last recorded point.
CutPoint allocate_cuts(const std::vector<EmbeddedStream>& streams, size_t budget);

}  // namespace tesswave::video
