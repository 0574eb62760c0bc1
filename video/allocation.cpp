#include "allocation.h"

#include <algorithm>
#include <cmath>

namespace tesswave::video {
namespace {

// The stream's size once truncation point r (0: the first pass of the top sweep of the whole
// group, `top` sweeps in all) is reached: 0 before its own top sweep starts, SIZE_MAX where its
// encoder stopped before.
size_t size_at(const EmbeddedStream& s, size_t top, size_t r) {
    const size_t t = top - 1 - r / 3, pass = r % 3;
    const size_t i = 3 * t + pass;
    if (i >= s.pass_ends.size()) return 0;
    return std::min(s.pass_ends[i], s.pass_ends[i] == SIZE_MAX ? SIZE_MAX : s.size);
}

}  // namespace

CutPoint allocate_cuts(const std::vector<EmbeddedStream>& streams, size_t budget) {
    CutPoint cut;
    std::vector<size_t>& cuts = cut.bytes;
    cuts.assign(streams.size(), 0);
    size_t whole = 0, top = 0;
    bool capped = false;
    for (const EmbeddedStream& s : streams) {
        whole += s.size;
        top = std::max(top, s.pass_ends.size() / 3);
        capped = capped ||
                 std::find(s.pass_ends.begin(), s.pass_ends.end(), SIZE_MAX) != s.pass_ends.end();
    }
    if (whole <= budget && !capped) {
        for (size_t k = 0; k < streams.size(); ++k) cuts[k] = streams[k].size;
        return cut;
    }
    // The last point whose sum fits; points are taken in order until one does not.
    const auto total = [&](size_t r) {
        size_t sum = 0;
        for (const EmbeddedStream& s : streams) {
            const size_t b = size_at(s, top, r);
            if (b == SIZE_MAX) return SIZE_MAX;
            sum += b;
        }
        return sum;
    };
    const size_t points = 3 * top;
    if (points == 0) return cut;
    size_t r = 0;
    while (r < points && total(r) <= budget) ++r;
    // Points [0, r) fit; r (if any) does not. Streams at point r - 1, then a share of point r.
    std::vector<size_t> below(streams.size(), 0), above(streams.size(), 0);
    size_t sum_below = 0, sum_step = 0;
    for (size_t k = 0; k < streams.size(); ++k) {
        below[k] = r > 0 ? size_at(streams[k], top, r - 1) : 0;
        above[k] = r < points ? size_at(streams[k], top, r) : streams[k].size;
        if (above[k] == SIZE_MAX) above[k] = std::max(streams[k].size, below[k]);
        above[k] = std::min(above[k], streams[k].size);
        sum_below += below[k];
        sum_step += above[k] - below[k];
    }
    const double f = sum_step > 0
                         ? std::clamp(static_cast<double>(budget - std::min(budget, sum_below)) /
                                          static_cast<double>(sum_step),
                                      0.0, 1.0)
                         : 0.0;
    for (size_t k = 0; k < streams.size(); ++k) {
        cuts[k] = below[k] +
                  static_cast<size_t>(std::floor(f * static_cast<double>(above[k] - below[k])));
    }
    cut.sweep = static_cast<int>(top - 1 - std::min(r, points - 1) / 3);
    return cut;
}

}  // namespace tesswave::video
