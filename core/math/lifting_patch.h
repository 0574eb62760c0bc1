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
          v2_(side_),
          h0_(m_),
          h1_(m_),
          vt_(side_),
          inc_(side_) {}

    // The whole step inside patch p (kSign = +1 decomposes, -1 reconstructs), row by row so
    // that each vertex row is gathered once and the rows it touches are still in cache. Each
    // row's increments read exactly what the separate passes f', e', v' (forward) or v', e', f'
    // (inverse) would give them:
    //   forward, row r: faces of row r (edges and vertices around them untouched), its edges
    //     (faces r - 1 and r done, vertices untouched), then the vertices of row r (every face
    //     and edge around them done; no later row reads them);
    //   inverse, row r: the vertices of row r + 1 (the faces and edges around them still
    //     primed), the edges of row r (vertex rows r and r + 1 restored, faces r - 1 and r still
    //     primed), then the faces of row r - 1 (the edges and vertices around them restored).
    template <int kSign>
    void run(int32_t p) {
        T* prev = v0_.data();  // vertex rows r - 1, r and r + 1, the buffers taking turns
        T* row = v1_.data();
        T* next = v2_.data();
        gather_row(p, 0, row);
        for (int32_t r = 0; r < m_; ++r) {
            if (kSign < 0 && r + 1 < m_) vertex_row<kSign>(p, r + 1);
            gather_row(p, r + 1, next);
            if (kSign > 0) face_row<kSign>(p, r, row, next);
            edge_row<kSign>(p, r, row, next);
            if (kSign > 0 && r > 0) vertex_row<kSign>(p, r);
            if (kSign < 0 && r > 0) face_row<kSign>(p, r - 1, prev, row);
            T* const spare = prev;
            prev = row;
            row = next;
            next = spare;
        }
        if (kSign < 0) face_row<kSign>(p, m_ - 1, prev, row);
    }

  private:
    // f' for the faces of row r of patch p, between vertex rows r (v0) and r + 1 (v1).
    template <int kSign>
    void face_row(int32_t p, int32_t r, const T* __restrict v0, const T* __restrict v1) {
        const T* __restrict h0 = horizontal_row(p, r, h0_.data());
        const T* __restrict h1 = horizontal_row(p, r + 1, h1_.data());
        const T* __restrict vt = vertical_row(p, r);
        T* __restrict f = x_ + n_ + E_ + (p * m_ + r) * m_;
        for (int32_t c = 0; c < m_; ++c) {
            const Acc sv = Acc{0} + v0[c] + v0[c + 1] + v1[c + 1] + v1[c];
            const Acc se = Acc{0} + h0[c] + vt[c + 1] + h1[c] + vt[c];
            f[c] += kSign * Rule::apply(sv - 2 * se, 4);
        }
    }

    // e' for the interior edges of row r of patch p: the horizontal ones on vertex row r (v0),
    // between face rows r - 1 and r, and the vertical ones between vertex rows r and r + 1 (v1).
    template <int kSign>
    void edge_row(int32_t p, int32_t r, const T* __restrict v0, const T* __restrict v1) {
        const T* __restrict f = x_ + n_ + E_ + (p * m_ + r) * m_;
        T* hb = x_ + n_ + S_ + p * 2 * m_ * (m_ - 1);
        if (r > 0) {
            T* __restrict e = hb + (r - 1) * m_;
            const T* __restrict below = f - m_;
            for (int32_t c = 0; c < m_; ++c) {
                const Acc sv = Acc{v0[c]} + v0[c + 1];
                e[c] += kSign * Rule::apply(Acc{below[c]} + f[c] - 2 * sv, 4);
            }
        }
        T* __restrict e =
            hb + m_ * (m_ - 1) + r * (m_ - 1) - 1;  // vertical edges (r, c), 0 < c < m
        for (int32_t c = 1; c < m_; ++c) {
            const Acc sv = Acc{v0[c]} + v1[c];
            e[c] += kSign * Rule::apply(Acc{f[c - 1]} + f[c] - 2 * sv, 4);
        }
    }

    // v' for the vertices of row r (0 < r < m) strictly inside patch p (all regular: 4 edges,
    // 4 faces).
    template <int kSign>
    void vertex_row(int32_t p, int32_t r) {
        const T* faces = x_ + n_ + E_ + p * m_ * m_;
        const T* hb = x_ + n_ + S_ + p * 2 * m_ * (m_ - 1);
        const T* vb = hb + m_ * (m_ - 1);
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
        const int32_t* ids = &t_.patch_grid[(p * side_ + r) * side_];
        for (int32_t c = 1; c < m_; ++c) x_[ids[c]] += kSign * inc[c];
    }

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
    std::vector<T> v0_, v1_, v2_, h0_, h1_, vt_, inc_;
};

}  // namespace tesswave::detail
