// The one progress callback of the libraries: the fraction of the job done, in [0, 1], and what it
// is doing. A caller that runs several jobs in a row maps each into its share of one bar with
// progress_range, so that the bar moves steadily instead of jumping.
#pragma once

#include <functional>

namespace tesswave {

using Progress = std::function<void(double done, const char* stage)>;

// Reports of `inner` in [0, 1] as [from, to] of `outer` (nothing when `outer` is empty).
inline Progress progress_range(const Progress& outer, double from, double to) {
    if (!outer) return {};
    return [outer, from, to](double done, const char* stage) {
        outer(from + (to - from) * done, stage);
    };
}

// Calls `p` if it is set.
inline void report(const Progress& p, double done, const char* stage) {
    if (p) p(done, stage);
}

}  // namespace tesswave
