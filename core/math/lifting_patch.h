// Internal: the lifting step inside the patches of a level with m >= 2 cells a side, as row loops
// over the patch grids (see LevelTopology::patch_grid). Faces, interior edges and interior
// vertices of a patch sit in contiguous rows, so the loops stream and vectorize; only the vertex
// values are gathered (and scattered) through the grid of vertex ids. The sums are those of
// Step in the same order, so the results are bit-identical to the reference.
#pragma once

#include <vector>

#include "core/math/lifting_rules.h"
#include "core/math/patch_grid.h"

namespace tesswave::detail {

template <class Rule>
class PatchStep {
  public:
    using T = typename Rule::T;
    using Acc = typename Rule::Acc;

    PatchStep(const LevelTopology& t, const PatchSides& ps, T* x)
        : t_(t),
          ps_(ps),
          x_(x),
          m_(t.patch_cells),
          side_(t.patch_cells + 1),
          n_(t.n_vertices),
          E_(t.num_edges()),
          S_(ps.num_t1_edges * t.patch_cells),
          v0_(side_),
          v1_(side_),
          h0_(m_),
          h1_(m_),
          vt_(side_),
          inc_(side_) {}

    // f' for every face of patch p (kSign = +1 decomposes, -1 reconstructs).
    template <int kSign>
    void faces(int32_t p) {
        gather_row(p, 0, v0_.data());
        for (int32_t r = 0; r < m_; ++r) {
            gather_row(p, r + 1, v1_.data());
            const T* __restrict h0 = horizontal_row(p, r, h0_.data());
            const T* __restrict h1 = horizontal_row(p, r + 1, h1_.data());
            const T* __restrict vt = vertical_row(p, r);
            const T* __restrict v0 = v0_.data();
            const T* __restrict v1 = v1_.data();
            T* __restrict f = x_ + n_ + E_ + (p * m_ + r) * m_;
            for (int32_t c = 0; c < m_; ++c) {
                const Acc sv = Acc{0} + v0[c] + v0[c + 1] + v1[c + 1] + v1[c];
                const Acc se = Acc{0} + h0[c] + vt[c + 1] + h1[c] + vt[c];
                f[c] += kSign * Rule::apply(sv - 2 * se, 4);
            }
            std::swap(v0_, v1_);
        }
    }

    // e' for the interior edges of patch p.
    template <int kSign>
    void edges(int32_t p) {
        const T* faces = x_ + n_ + E_ + p * m_ * m_;
        T* hb = x_ + n_ + S_ + p * 2 * m_ * (m_ - 1);
        T* vb = hb + m_ * (m_ - 1);
        gather_row(p, 0, v0_.data());
        for (int32_t r = 0; r < m_; ++r) {
            gather_row(p, r + 1, v1_.data());
            const T* __restrict v0 = v0_.data();
            const T* __restrict v1 = v1_.data();
            const T* __restrict f = faces + r * m_;
            if (r > 0) {  // horizontal edges of row r, between face rows r-1 and r
                T* __restrict e = hb + (r - 1) * m_;
                const T* __restrict below = f - m_;
                for (int32_t c = 0; c < m_; ++c) {
                    const Acc sv = Acc{v0[c]} + v0[c + 1];
                    e[c] += kSign * Rule::apply(Acc{below[c]} + f[c] - 2 * sv, 4);
                }
            }
            T* __restrict e = vb + r * (m_ - 1) - 1;  // vertical edges (r, c), 0 < c < m
            for (int32_t c = 1; c < m_; ++c) {
                const Acc sv = Acc{v0[c]} + v1[c];
                e[c] += kSign * Rule::apply(Acc{f[c - 1]} + f[c] - 2 * sv, 4);
            }
            std::swap(v0_, v1_);
        }
    }

    // v' for the vertices strictly inside patch p (all regular: 4 edges, 4 faces).
    template <int kSign>
    void vertices(int32_t p) {
        const T* faces = x_ + n_ + E_ + p * m_ * m_;
        const T* hb = x_ + n_ + S_ + p * 2 * m_ * (m_ - 1);
        const T* vb = hb + m_ * (m_ - 1);
        const int32_t* grid = &t_.patch_grid[p * side_ * side_];
        for (int32_t r = 1; r < m_; ++r) {
            // Star order: edges by id (H(r,c-1), H(r,c), V(r-1,c), V(r,c)), faces by id.
            const T* __restrict h = hb + (r - 1) * m_;
            const T* __restrict va = vb + (r - 1) * (m_ - 1) - 1;
            const T* __restrict vc = vb + r * (m_ - 1) - 1;
            const T* __restrict fa = faces + (r - 1) * m_;
            const T* __restrict fc = faces + r * m_;
            T* __restrict inc = inc_.data();
            for (int32_t c = 1; c < m_; ++c) {
                const Acc se = Acc{0} + h[c - 1] + h[c] + va[c] + vc[c];
                const Acc sf = Acc{0} + fa[c - 1] + fa[c] + fc[c - 1] + fc[c];
                inc[c] = Step<Rule>::regular_vertex(se, sf);
            }
            const int32_t* ids = grid + r * side_;
            for (int32_t c = 1; c < m_; ++c) x_[ids[c]] += kSign * inc[c];
        }
    }

  private:
    void gather_row(int32_t p, int32_t r, T* out) const {
        const int32_t* ids = &t_.patch_grid[(p * side_ + r) * side_];
        for (int32_t c = 0; c <= m_; ++c) out[c] = x_[ids[c]];
    }
    // Horizontal edges (r, 0..m-1): in place inside the patch, gathered on the skeleton.
    const T* horizontal_row(int32_t p, int32_t r, T* buffer) const {
        if (r > 0 && r < m_) return x_ + n_ + S_ + p * 2 * m_ * (m_ - 1) + (r - 1) * m_;
        for (int32_t c = 0; c < m_; ++c) buffer[c] = x_[n_ + horizontal_edge(ps_, p, r, c, m_)];
        return buffer;
    }
    // Vertical edges (r, 0..m): the two ends lie on the skeleton.
    const T* vertical_row(int32_t p, int32_t r) {
        const T* inner = x_ + n_ + S_ + p * 2 * m_ * (m_ - 1) + m_ * (m_ - 1) + r * (m_ - 1);
        vt_[0] = x_[n_ + vertical_edge(ps_, p, r, 0, m_)];
        for (int32_t c = 1; c < m_; ++c) vt_[c] = inner[c - 1];
        vt_[m_] = x_[n_ + vertical_edge(ps_, p, r, m_, m_)];
        return vt_.data();
    }

    const LevelTopology& t_;
    const PatchSides& ps_;
    T* x_;
    int32_t m_, side_, n_, E_, S_;
    std::vector<T> v0_, v1_, h0_, h1_, vt_, inc_;
};

}  // namespace tesswave::detail
