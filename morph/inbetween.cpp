#include "inbetween.h"

#include <algorithm>
#include <cmath>

#include "auto_match.h"
#include "core/math/grid_mesh.h"

namespace tesswave::morph {

PairMeshes automatic_pair(const Image& f0, const Image& f1, double cell) {
    const Matches m = auto_match(f0, f1);
    const int cols = std::max(1, static_cast<int>(std::lround(f0.width / cell)));
    const int rows = std::max(1, static_cast<int>(std::lround(f0.height / cell)));
    return fitted_pair(grid_mesh(f0.width, f0.height, cols, rows), {m.a, m.b}, f1.width, f1.height);
}

Image inbetween(const Image& f0, const Image& f1, double t, const InbetweenOptions& options) {
    const PairMeshes pair = automatic_pair(f0, f1, options.cell);
    return Morph(f0, f1, pair.a, pair.b, options.morph).frame(t);
}

}  // namespace tesswave::morph
