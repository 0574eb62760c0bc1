#include "core/math/selection.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/math/error.h"
#include "core/math/lifting.h"
#include "core/math/strings.h"

namespace tesswave {

double impulse_norm(const Hierarchy& h, int32_t begin, int32_t end, double domain_area, int probes,
                    std::vector<double>& scratch) {
    const int32_t size = end - begin, n = h.num_samples(h.finest());
    const int k = std::min<int32_t>(probes, size);
    if (k <= 0) return 1.0;
    scratch.resize(n);
    std::span<double> planes[] = {scratch};
    double sum = 0;
    for (int i = 0; i < k; ++i) {
        // Probes spread evenly through the band (its points are in mesh order).
        const int32_t id = begin + static_cast<int32_t>((int64_t{2 * i + 1} * size) / (2 * k));
        std::fill(scratch.begin(), scratch.end(), 0.0);
        scratch[id] = 1.0;
        inverse_transform(h, planes);
        double energy = 0;
        for (double v : scratch) energy += v * v;
        sum += std::sqrt(energy * (domain_area / n));
    }
    return sum / k;
}

std::vector<Band> mesh_bands(const Hierarchy& h, double domain_area, int probes) {
    const int J = h.finest();
    std::vector<Band> bands;
    for (int j = 0; j < J; ++j) {
        const LevelTopology& t = h.levels[j];
        const int32_t e0 = t.n_vertices, f0 = e0 + t.num_edges(), f1 = t.n_next();
        bands.push_back({j, 'e', e0, f0});
        bands.push_back({j, 'f', f0, f1});
    }
    std::vector<double> scratch;
    for (Band& band : bands) {
        band.norm = impulse_norm(h, band.begin, band.end, domain_area, probes, scratch);
    }
    return bands;
}

std::vector<float> band_weights(const std::vector<Band>& bands, int32_t size) {
    std::vector<float> w(size, 1.0f);
    for (const Band& b : bands) {
        std::fill(w.begin() + b.begin, w.begin() + b.end, static_cast<float>(b.norm));
    }
    return w;
}

int64_t keep_count(int64_t details, double percent) {
    if (!(percent > 0 && percent <= 100)) {
        throw Error(str("keep: ", percent, " % is outside (0, 100]"));
    }
    return std::llround(details * percent / 100.0);
}

int64_t keep_largest(std::span<const std::span<float>> planes, std::span<const int32_t> ids,
                     int64_t count, std::span<const float> weights) {
    const int64_t details = static_cast<int64_t>(ids.size());
    count = std::clamp<int64_t>(count, 0, details);
    std::vector<float> score(details);
    for (int64_t i = 0; i < details; ++i) {
        double sq = 0;
        for (auto plane : planes) sq += double{plane[ids[i]]} * plane[ids[i]];
        const float length = static_cast<float>(std::sqrt(sq));
        score[i] = weights.empty() ? length : length * weights[ids[i]];
    }
    std::vector<int32_t> order(details);
    std::iota(order.begin(), order.end(), 0);
    auto larger = [&](int32_t a, int32_t b) {
        return score[a] != score[b] ? score[a] > score[b] : a < b;
    };
    if (count < details)
        std::nth_element(order.begin(), order.begin() + count, order.end(), larger);
    std::vector<char> keep(details, 0);
    for (int64_t i = 0; i < count; ++i) keep[order[i]] = 1;
    for (auto plane : planes) {
        for (int64_t i = 0; i < details; ++i) {
            if (!keep[i]) plane[ids[i]] = 0.0f;
        }
    }
    return count;
}

int64_t keep_largest(std::span<const std::span<float>> planes, int32_t first_detail, int64_t count,
                     std::span<const float> weights) {
    if (planes.empty()) return 0;
    std::vector<int32_t> ids(planes[0].size() - first_detail);
    std::iota(ids.begin(), ids.end(), first_detail);
    return keep_largest(planes, ids, count, weights);
}

}  // namespace tesswave
