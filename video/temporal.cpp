#include "temporal.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

#include "core/math/error.h"

namespace tesswave::video {
namespace {

// x += wa a + wb b over every channel and coefficient.
void add_pair(Planes& x, const Planes& a, float wa, const Planes& b, float wb) {
    for (size_t c = 0; c < x.size(); ++c) {
        float* out = x[c].data();
        const float* pa = a[c].data();
        const float* pb = b[c].data();
        const size_t n = x[c].size();
        for (size_t i = 0; i < n; ++i) out[i] += wa * pa[i] + wb * pb[i];
    }
}

// One lifting step: slot `at` takes w_a times slot a and w_b times slot b (a == b: one neighbour,
// taken twice).
struct Step {
    size_t at, a, b;
    float wa, wb;
};

// One level of the tree: its predict steps (odd slots from the even ones around them), then its
// update steps (even slots from the odd ones next to them), with the forward weights.
struct Level {
    std::vector<Step> predict, update;
};

// The update of each even slot from the odd slots next to it in `order` (the level's slots in
// time order), a missing one mirrored.
void add_updates(Level& level, const std::vector<size_t>& order, const std::vector<bool>& odd) {
    for (size_t j = 0; j < order.size(); ++j) {
        if (odd[j]) continue;
        const bool left = j > 0 && odd[j - 1], right = j + 1 < order.size() && odd[j + 1];
        if (!left && !right) continue;
        const size_t a = order[left ? j - 1 : j + 1], b = order[right ? j + 1 : j - 1];
        level.update.push_back({order[j], a, b, 0.25f, 0.25f});
    }
}

// The dyadic tree's levels, finest first: level l works on slots j 2^l.
std::vector<Level> dyadic_levels(size_t n, int levels) {
    std::vector<Level> out;
    for (int l = 0; l < levels; ++l) {
        const size_t s = size_t{1} << l;
        const size_t m = (n + s - 1) / s;
        Level level;
        std::vector<size_t> order;
        std::vector<bool> odd;
        for (size_t j = 0; j < m; ++j) {
            order.push_back(j * s);
            odd.push_back(j % 2 == 1);
            if (j % 2 == 1) {
                const size_t right = j + 1 < m ? j + 1 : j - 1;
                level.predict.push_back({j * s, (j - 1) * s, right * s, -0.5f, -0.5f});
            }
        }
        add_updates(level, order, odd);
        out.push_back(std::move(level));
    }
    return out;
}

// The bisection tree's levels, finest first: built from the top (the last slot predicted from
// the first), then each span between neighbouring even slots halved while it is 2 or longer.
std::vector<Level> bisection_levels(size_t n) {
    std::vector<Level> coarse_first;
    if (n < 2) return coarse_first;
    Level top;
    top.predict.push_back({n - 1, 0, 0, -0.5f, -0.5f});
    top.update.push_back({0, n - 1, n - 1, 0.25f, 0.25f});
    coarse_first.push_back(std::move(top));
    std::vector<size_t> even = {0, n - 1};
    while (true) {
        Level level;
        std::vector<size_t> order;
        std::vector<bool> odd;
        for (size_t i = 0; i < even.size(); ++i) {
            order.push_back(even[i]);
            odd.push_back(false);
            if (i + 1 == even.size() || even[i + 1] - even[i] < 2) continue;
            const size_t l = even[i], r = even[i + 1], m = l + (r - l) / 2;
            const float wl = static_cast<float>(r - m) / static_cast<float>(r - l);
            level.predict.push_back({m, l, r, -wl, -(1.0f - wl)});
            order.push_back(m);
            odd.push_back(true);
        }
        if (level.predict.empty()) break;
        add_updates(level, order, odd);
        even = order;
        coarse_first.push_back(std::move(level));
    }
    return {coarse_first.rbegin(), coarse_first.rend()};
}

std::vector<Level> tree_levels(size_t n, int levels, TemporalTree tree) {
    std::vector<Level> all =
        tree == TemporalTree::dyadic ? dyadic_levels(n, levels) : bisection_levels(n);
    all.resize(static_cast<size_t>(levels));
    return all;
}

void check_frames(const std::vector<Planes>& frames, int levels, TemporalTree tree) {
    if (levels < 0 || levels > temporal_levels(static_cast<int>(frames.size()), tree)) {
        throw Error("temporal lifting: levels do not fit the group");
    }
    for (const Planes& f : frames) {
        if (f.size() != frames[0].size()) throw Error("temporal lifting: channel counts differ");
        for (size_t c = 0; c < f.size(); ++c) {
            if (f[c].size() != frames[0][c].size()) throw Error("temporal lifting: sizes differ");
        }
    }
}

void run(std::vector<Planes>& x, const std::vector<Step>& steps, float sign) {
    for (const Step& s : steps) add_pair(x[s.at], x[s.a], sign * s.wa, x[s.b], sign * s.wb);
}

}  // namespace

int temporal_levels(int n, TemporalTree tree) {
    if (n < 2) return 0;
    int levels = 0;
    if (tree == TemporalTree::dyadic) {
        while ((int64_t{1} << levels) < n) ++levels;
        return levels;
    }
    while ((int64_t{1} << levels) < n - 1) ++levels;
    return levels + 1;
}

void temporal_forward(std::vector<Planes>& frames, int levels, TemporalTree tree) {
    check_frames(frames, levels, tree);
    for (const Level& level : tree_levels(frames.size(), levels, tree)) {
        run(frames, level.predict, 1.0f);
        run(frames, level.update, 1.0f);
    }
}

void temporal_inverse(std::vector<Planes>& frames, int levels, TemporalTree tree) {
    check_frames(frames, levels, tree);
    const std::vector<Level> all = tree_levels(frames.size(), levels, tree);
    for (auto level = all.rbegin(); level != all.rend(); ++level) {
        run(frames, level->update, -1.0f);
        run(frames, level->predict, -1.0f);
    }
}

std::vector<double> temporal_norms(int n, int levels, TemporalTree tree) {
    std::vector<double> norms(static_cast<size_t>(n));
    for (int t = 0; t < n; ++t) {
        std::vector<Planes> x(static_cast<size_t>(n), Planes{std::vector<float>(1, 0.0f)});
        x[static_cast<size_t>(t)][0][0] = 1.0f;
        temporal_inverse(x, levels, tree);
        double sum = 0;
        for (const Planes& f : x) sum += double{f[0][0]} * f[0][0];
        norms[static_cast<size_t>(t)] = std::sqrt(sum);
    }
    return norms;
}

}  // namespace tesswave::video
