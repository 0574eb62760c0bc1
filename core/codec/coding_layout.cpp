#include "core/codec/coding_layout.h"

#include <algorithm>
#include <cmath>
#include <span>

#include "core/math/parallel.h"
#include "core/math/selection.h"

namespace tesswave {
namespace {

// Ends the CSR offset arrays and builds the children lists from the parents.
void close_lists(CodingLayout& layout) {
    layout.nb_offsets.push_back(static_cast<int32_t>(layout.nb.size()));
    layout.pa_offsets.push_back(static_cast<int32_t>(layout.pa.size()));
    layout.ch_offsets.assign(static_cast<size_t>(layout.size) + 1, 0);
    for (int32_t p : layout.pa) ++layout.ch_offsets[p + 1];
    for (int32_t i = 0; i < layout.size; ++i) layout.ch_offsets[i + 1] += layout.ch_offsets[i];
    layout.ch.resize(layout.pa.size());
    std::vector<int32_t> fill(layout.ch_offsets.begin(), layout.ch_offsets.end() - 1);
    for (size_t k = 0; k < layout.order.size(); ++k) {
        for (int32_t i = layout.pa_offsets[k]; i < layout.pa_offsets[k + 1]; ++i) {
            layout.ch[fill[layout.pa[i]]++] = layout.order[k];
        }
    }
}

// Fills a layout's lists through cursors into arrays sized from above (the entries exactly, at
// most nb_bound neighbours and pa_bound parents), then cuts them to what was written and closes
// them: the one way both layouts are built.
class LayoutWriter {
  public:
    LayoutWriter(CodingLayout& layout, size_t entries, size_t nb_bound, size_t pa_bound)
        : layout_(layout) {
        layout.order.resize(entries);
        layout.nb_primary.assign(entries, 0);
        layout.nb_offsets.resize(entries);
        layout.pa_offsets.resize(entries);
        layout.nb.resize(nb_bound);
        layout.pa.resize(pa_bound);
        order_ = layout.order.data();
        primary_ = layout.nb_primary.data();
        nb_offsets_ = layout.nb_offsets.data();
        pa_offsets_ = layout.pa_offsets.data();
        nb_ = layout.nb.data();
        pa_ = layout.pa.data();
    }

    // The next entry, coefficient `id`; its neighbours and parents follow.
    void start(int32_t id) {
        order_[k_] = id;
        nb_offsets_[k_] = nbn_;
        pa_offsets_[k_++] = pan_;
    }
    void neighbour(int32_t id) { nb_[nbn_++] = id; }
    void add_primary() { ++primary_[k_ - 1]; }  // the last neighbour is a primary one
    void set_primary(int count) { primary_[k_ - 1] = static_cast<uint8_t>(count); }
    void parent(int32_t id) { pa_[pan_++] = id; }
    int32_t position() const { return k_; }

    void finish() {
        layout_.nb.resize(static_cast<size_t>(nbn_));
        layout_.pa.resize(static_cast<size_t>(pan_));
        close_lists(layout_);
    }

  private:
    CodingLayout& layout_;
    int32_t *order_, *nb_offsets_, *pa_offsets_, *nb_, *pa_;
    uint8_t* primary_;
    int32_t k_ = 0, nbn_ = 0, pan_ = 0;
};

}  // namespace

CodingLayout mesh_layout(const Hierarchy& h, double domain_area, int probes) {
    const int J = h.finest();
    const int32_t n = h.num_samples(J), n0 = h.num_samples(0);
    CodingLayout layout;
    layout.size = n;
    std::vector<double> scratch;
    auto norm = [&](int32_t begin, int32_t end) {
        return impulse_norm(h, begin, end, domain_area, probes, scratch);
    };
    // The lists are filled through cursors into arrays sized from above: an edge point of a face
    // with k corners lists at most the opposite edge, the face and its k - 1 other edges; a face
    // point its k neighbours and k edges. Parents: two an edge, k a face.
    size_t nb_bound = 0, pa_bound = 0;
    for (int j = 0; j < J; ++j) {
        const LevelTopology& t = h.levels[j];
        for (int32_t f = 0; f < t.num_faces(); ++f) {
            const size_t k = static_cast<size_t>(t.face_offsets[f + 1] - t.face_offsets[f]);
            nb_bound += k * (k + 1) + 2 * k;
            pa_bound += k;
        }
        pa_bound += 2 * static_cast<size_t>(t.num_edges());
    }
    LayoutWriter w(layout, static_cast<size_t>(n), nb_bound, pa_bound);
    auto parent = [&](int32_t id) {
        if (id >= n0) w.parent(id);
    };

    layout.bands.push_back({-1, 'v', 0, n0, norm(0, n0)});
    for (int32_t i = 0; i < n0; ++i) w.start(i);
    for (int j = 0; j < J; ++j) {
        const LevelTopology& t = h.levels[j];
        const int32_t e0 = t.n_vertices, f0 = e0 + t.num_edges(), f1 = t.n_next();
        // Edge points.
        layout.bands.push_back({j, 'e', e0, f0, norm(e0, f0)});
        for (int32_t e = 0; e < t.num_edges(); ++e) {
            w.start(e0 + e);
            // Primary: the opposite edge in each face with an even number of corners (on a
            // grid, the EBCOT neighbours across the edge's own direction).
            int32_t opposite[2] = {-1, -1};
            for (int s = 0; s < 2; ++s) {
                const int32_t f = t.edge_f[e][s];
                if (f < 0) continue;
                const int32_t begin = t.face_offsets[f], corners = t.face_offsets[f + 1] - begin;
                if (corners % 2) continue;
                for (int32_t c = 0; c < corners; ++c) {
                    if (t.face_e[begin + c] == e) {
                        opposite[s] = t.face_e[begin + (c + corners / 2) % corners];
                        break;
                    }
                }
            }
            for (int s = 0; s < 2; ++s) {
                if (t.edge_f[e][s] >= 0 && opposite[s] >= 0) {
                    w.neighbour(e0 + opposite[s]);
                    w.add_primary();
                }
            }
            for (int s = 0; s < 2; ++s) {
                const int32_t f = t.edge_f[e][s];
                if (f < 0) continue;
                w.neighbour(f0 + f);
                for (int32_t c = t.face_offsets[f]; c < t.face_offsets[f + 1]; ++c) {
                    if (t.face_e[c] != e && t.face_e[c] != opposite[s])
                        w.neighbour(e0 + t.face_e[c]);
                }
            }
            parent(t.edge_v[e][0]);
            parent(t.edge_v[e][1]);
        }
        // Face points.
        layout.bands.push_back({j, 'f', f0, f1, norm(f0, f1)});
        for (int32_t f = 0; f < t.num_faces(); ++f) {
            w.start(f0 + f);
            // Primary: the faces across its edges; then its edge points.
            for (int32_t c = t.face_offsets[f]; c < t.face_offsets[f + 1]; ++c) {
                const auto& ef = t.edge_f[t.face_e[c]];
                const int32_t other = ef[0] == f ? ef[1] : ef[0];
                if (other >= 0) {
                    w.neighbour(f0 + other);
                    w.add_primary();
                }
            }
            for (int32_t c = t.face_offsets[f]; c < t.face_offsets[f + 1]; ++c) {
                w.neighbour(e0 + t.face_e[c]);
                parent(t.face_v[c]);
            }
        }
    }
    w.finish();
    // Bands hold positions in `order`; for the mesh these equal the coefficient ids.
    return layout;
}

// Band norms from centre impulses, on a plane just large enough for the coarsest basis functions
// (12 cells of the coarsest level a side): the bands are translation invariant inside, so this
// equals the full plane's norms while costing a fraction of its transforms.
std::vector<double> grid_band_norms(int width, int height, int levels, GridWavelet wavelet) {
    const int64_t reach = int64_t{12} << std::min(levels, 24);
    const int w = static_cast<int>(std::min<int64_t>(width, reach));
    const int h = static_cast<int>(std::min<int64_t>(height, reach));
    const std::vector<GridBand> bands = grid_bands(w, h, levels);
    std::vector<double> norms(bands.size());
    // A band a thread: each synthesizes an impulse at the band's centre.
    parallel_tasks(static_cast<int64_t>(bands.size()), [&](int64_t b) {
        const GridBand& g = bands[static_cast<size_t>(b)];
        std::vector<float> x(static_cast<size_t>(w) * h, 0.0f);
        x[static_cast<size_t>(g.y0 + g.height / 2) * w + g.x0 + g.width / 2] = 1.0f;
        grid_inverse(x, w, h, {.wavelet = wavelet, .levels = levels});
        double energy = 0;
        for (float v : x) energy += double{v} * v;
        norms[static_cast<size_t>(b)] = std::sqrt(energy);
    });
    return norms;
}

CodingLayout grid_layout(int width, int height, int levels, GridWavelet wavelet, bool norms,
                         GridRelations relations) {
    CodingLayout layout;
    layout.size = width * height;
    const std::vector<GridBand> bands = grid_bands(width, height, levels);
    const char types[] = {'L', 'H', 'V', 'D'};
    std::vector<double> band_norms(bands.size(), 1.0);
    if (norms) {
        band_norms = grid_band_norms(width, height, levels, wavelet);
        if (band_norms.size() != bands.size()) band_norms.assign(bands.size(), 1.0);
    }
    // The band of the same orientation one level coarser (none for the LL band and the coarsest
    // details).
    auto coarser = [&](size_t b) -> const GridBand* {
        const GridBand& g = bands[b];
        return g.type != 0 && b >= 4 && bands[b - 3].level == g.level + 1 ? &bands[b - 3] : nullptr;
    };
    if (relations == GridRelations::computed) {
        layout.order.resize(static_cast<size_t>(layout.size));
        int32_t k = 0;
        for (size_t b = 0; b < bands.size(); ++b) {
            const GridBand& g = bands[b];
            const int32_t begin = k;
            for (int y = 0; y < g.height; ++y) {
                for (int x = 0; x < g.width; ++x) layout.order[k++] = (g.y0 + y) * width + g.x0 + x;
            }
            layout.bands.push_back({g.level, types[g.type], begin, k, band_norms[b]});
        }
        layout.grid_width = width;
        layout.grid_bands = bands;
        layout.grid_child_band.assign(bands.size(), -1);
        for (size_t b = 0; b < bands.size(); ++b) {
            if (coarser(b)) layout.grid_child_band[b - 3] = static_cast<int32_t>(b);
        }
        return layout;
    }
    const auto size = static_cast<size_t>(layout.size);
    // One entry a coefficient; at most 8 neighbours and 1 parent each.
    LayoutWriter w(layout, size, size * 8, size);
    for (size_t b = 0; b < bands.size(); ++b) {
        const GridBand& g = bands[b];
        const int32_t begin = w.position();
        const GridBand* parents = coarser(b);
        // The 8 neighbour offsets, primary ones first.
        int dxs[8], dys[8], n = 0, primaries = 0;
        for (bool primary : {true, false}) {
            for (int dy = -1; dy <= 1; ++dy) {
                for (int dx = -1; dx <= 1; ++dx) {
                    if ((dx || dy) && grid_primary(g.type, dx, dy) == primary) {
                        dxs[n] = dx;
                        dys[n++] = dy;
                        primaries += primary;
                    }
                }
            }
        }
        for (int y = 0; y < g.height; ++y) {
            const int32_t row = (g.y0 + y) * width + g.x0;
            for (int xx = 0; xx < g.width; ++xx) {
                const int32_t id = row + xx;
                w.start(id);
                int count = 0;
                for (int i = 0; i < 8; ++i) {
                    const int yy = y + dys[i], xn = xx + dxs[i];
                    if (yy < 0 || yy >= g.height || xn < 0 || xn >= g.width) continue;
                    w.neighbour(id + dys[i] * width + dxs[i]);
                    count += i < primaries;
                }
                w.set_primary(count);
                if (parents) {
                    const int py = std::min(y / 2, parents->height - 1);
                    const int px = std::min(xx / 2, parents->width - 1);
                    w.parent((parents->y0 + py) * width + parents->x0 + px);
                }
            }
        }
        layout.bands.push_back({g.level, types[g.type], begin, w.position(), band_norms[b]});
    }
    w.finish();
    return layout;
}

}  // namespace tesswave
