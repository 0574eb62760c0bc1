#include "temporal.h"

#include <cmath>
#include <span>

#include "core/math/error.h"

namespace tesswave::video {
namespace {

// x += w (a + b) over every channel and coefficient.
void add_pair(Planes& x, const Planes& a, const Planes& b, float w) {
    for (size_t c = 0; c < x.size(); ++c) {
        float* out = x[c].data();
        const float* pa = a[c].data();
        const float* pb = b[c].data();
        const size_t n = x[c].size();
        for (size_t i = 0; i < n; ++i) out[i] += w * (pa[i] + pb[i]);
    }
}

void check_frames(const std::vector<Planes>& frames, int levels) {
    if (levels < 0 || levels > temporal_levels(static_cast<int>(frames.size()))) {
        throw Error("temporal lifting: levels do not fit the group");
    }
    for (const Planes& f : frames) {
        if (f.size() != frames[0].size()) throw Error("temporal lifting: channel counts differ");
        for (size_t c = 0; c < f.size(); ++c) {
            if (f[c].size() != frames[0][c].size()) throw Error("temporal lifting: sizes differ");
        }
    }
}

// One level at stride s: slots j s, j = 0 .. m - 1. `sign` +1 runs the forward steps, -1 undoes
// them in reverse order.
void lift_level(std::vector<Planes>& x, size_t s, bool forward) {
    const size_t m = (x.size() + s - 1) / s;
    if (m < 2) return;
    const auto at = [&](size_t j) -> Planes& { return x[j * s]; };
    const auto predict = [&](float w) {
        for (size_t j = 1; j < m; j += 2)
            add_pair(at(j), at(j - 1), at(j + 1 < m ? j + 1 : j - 1), w);
    };
    const auto update = [&](float w) {
        for (size_t j = 0; j < m; j += 2) {
            const size_t left = j > 0 ? j - 1 : j + 1;
            const size_t right = j + 1 < m ? j + 1 : left;
            add_pair(at(j), at(left), at(right), w);
        }
    };
    if (forward) {
        predict(-0.5f);
        update(0.25f);
    } else {
        update(-0.25f);
        predict(0.5f);
    }
}

}  // namespace

int temporal_levels(int n) {
    int levels = 0;
    while ((1 << levels) < n) ++levels;
    return levels;
}

void temporal_forward(std::vector<Planes>& frames, int levels) {
    check_frames(frames, levels);
    for (int l = 0; l < levels; ++l) lift_level(frames, size_t{1} << l, true);
}

void temporal_inverse(std::vector<Planes>& frames, int levels) {
    check_frames(frames, levels);
    for (int l = levels - 1; l >= 0; --l) lift_level(frames, size_t{1} << l, false);
}

std::vector<double> temporal_norms(int n, int levels) {
    std::vector<double> norms(static_cast<size_t>(n));
    for (int t = 0; t < n; ++t) {
        std::vector<Planes> x(static_cast<size_t>(n), Planes{std::vector<float>(1, 0.0f)});
        x[static_cast<size_t>(t)][0][0] = 1.0f;
        temporal_inverse(x, levels);
        double sum = 0;
        for (const Planes& f : x) sum += double{f[0][0]} * f[0][0];
        norms[static_cast<size_t>(t)] = std::sqrt(sum);
    }
    return norms;
}

}  // namespace tesswave::video
