// The projection's linear algebra (project.cpp): the normal matrix as per-quad stencils, and the
// conjugate-gradient vectors on the quads' own grids, with the kernels that work on them. Internal
// to the math layer.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

namespace tesswave::detail {

using Planes = std::vector<std::vector<float>>;

// R^T M R + beta u L as a 3x3 stencil for every node of every quad's (m+1)^2 grid, entry
// (dr + 1) * 3 + (dc + 1) for the neighbour dr rows and dc columns away; a node shared by several
// quads sums their stencils. `diagonal` holds the whole matrix's diagonal, alpha u included.
struct NormalMatrix {
    int32_t side = 0, grid_size = 0;
    size_t quads = 0;
    const int32_t* grid = nullptr;     // the plan's sample ids, grid_size a quad
    std::unique_ptr<float[]> stencil;  // per quad, 9 planes of grid_size values (entry-major)
    std::vector<double> diagonal;

    float* entry(size_t q, int e) { return stencil.get() + (q * 9 + e) * grid_size; }
    const float* entry(size_t q, int e) const { return stencil.get() + (q * 9 + e) * grid_size; }
    double alpha = 0;             // alpha u
    std::vector<int64_t> pixels;  // per quad, the pixels it renders
};

constexpr int stencil_entry(int dr, int dc) { return (dr + 1) * 3 + (dc + 1); }

// Which grid nodes of the quads are shared by several quads (the rest, a quad's own, are written
// by that quad alone): per quad, the positions of its shared nodes.
struct SharedNodes {
    std::vector<uint8_t> shared;      // per quad and grid position
    std::vector<int32_t> offsets, k;  // per quad, [offsets[q], offsets[q + 1]) of k
};

// The positions of the shared nodes of every quad.
SharedNodes find_shared(const NormalMatrix& A, size_t samples);

// Adds the values stashed for the shared nodes (one per entry of s.k) to `plane` at their sample
// ids, in quad order: the same sums whatever the thread count.
void add_stashed(const NormalMatrix& A, const SharedNodes& s, const float* stash, float* plane);

// The solver's vectors, per channel, live in the quads' grids: quad q's side^2 values, row by row
// as in the plan, one quad after the other, so that the stencil reads a node's neighbours at fixed
// offsets and no value is fetched through its sample id. A stencil entry that points out of its
// quad's grid is zero (R^T R and the smoothness couple nodes of one quad only), so what such a read
// finds (the next row, the next quad, or the zero margin at either end) counts for nothing. A
// sample on the border of several quads has a copy in each, and every copy holds the same value
// (each is updated by the same arithmetic on the same values). Dot products count a sample once,
// at its first copy. The vectors are (side / (side - 1))^2 times the samples: 1.06 at 32 cells a
// side, 2.25 at 2, 4 at 1.
struct LocalGrids {
    int32_t side = 0, grid_size = 0;
    size_t margin = 0, size = 0;  // margin: zeros before the first quad and after the last
    std::vector<float> owner;     // 1 at each sample's first copy, else 0 (the margins too)
    // The shared samples, each with [offsets[i], offsets[i + 1]) of `copy` and `stashed`: its
    // copies' local indices, in quad order, and where each copy's product waits (SharedNodes').
    std::vector<int32_t> offsets, copy, stashed;

    size_t index(size_t q, int32_t k) const { return margin + q * grid_size + k; }
};

LocalGrids make_local(const NormalMatrix& A, const SharedNodes& s, size_t samples);

// The local copies of a plane of samples, and back (from each sample's first copy).
void to_local(const NormalMatrix& A, const LocalGrids& g, const std::vector<float>& plane,
              std::vector<float>& local);
void from_local(const NormalMatrix& A, const LocalGrids& g, const std::vector<float>& local,
                std::vector<float>& plane);

// y_c = A x_c for the channels c in `active`, on the local grids, the quads shared among the cores:
// per quad, the stencil applied row by row (entry-major, so the rows vectorize). An unshared node
// gets y = alpha u x + its product at once; a shared node's product waits in `products`, and its
// copies then get alpha u x plus the products of all its quads, added in quad order, so that every
// sum is made in the same order whatever the thread count.
// With `dots`, also x_c . y_c per active channel, each sample counted once: summed per quad (its
// own nodes) and per shared sample, then in that order, so the same whatever the thread count.
void multiply(const NormalMatrix& A, const SharedNodes& s, const LocalGrids& g, const Planes& x,
              Planes& y, const std::vector<int>& active, std::vector<float>& products,
              std::vector<double>* dots = nullptr);

// A block preconditioner with the quads as blocks (additive Schwarz, the quads overlapping on their
// shared border nodes): on each quad the Jacobi-scaled stencil is approximated by a product of two
// tridiagonal matrices with constant coefficients, one along the rows and one along the columns,
//     D^(-1/2) A_q D^(-1/2)  ~  (T_x + eps I) (x) (T_y + eps I),   T = tridiag(a, 1, a),
// with a the quad's mean scaled coupling to its horizontal (vertical) neighbours and eps the square
// root of the damping's part of the diagonal. A quad with more than 1.4 cells a pixel keeps the
// diagonal alone (Jacobi): the data term there is no longer a smooth blur (samples outnumber the
// pixels, many see one or none), and Jacobi converges in a few iterations (Kodak at 1.5 and 2
// samples a pixel: above 60 dB after 4 iterations, where the line solves needed 6 to 8). Rendering
// about a pixel apart blurs like [1 2 1] / 4 along each axis, whose normal matrix is nearly
// singular at the highest frequencies, where Jacobi leaves the conjugate gradients to find them one
// by one; the two line solves invert that blur. z = sum over quads q of S_q M_q^-1 S_q r, S_q =
// D^(-1/2) / sqrt(copies) on q's grid: symmetric, positive definite, and the same at every copy of
// a shared node.
struct LinePreconditioner {
    int32_t side = 0;
    std::vector<float> scale;  // per local-grid index: D^(-1/2) / sqrt(copies), 0 in the margins
    // Per quad and direction (0: along a row, 1: along a column): the coupling a, then the LDL^T
    // factors of tridiag(a, 1 + eps, a) of size side: side multipliers and side inverse pivots.
    std::vector<float> factors;   // per quad: 2 x (1 + 2 side)
    std::vector<uint8_t> solves;  // per quad: 1 where the line solves run, 0 where Jacobi's does
    bool any = false;             // some quad runs the line solves

    const float* of(size_t q, int direction) const {
        return factors.data() + (q * 2 + direction) * (1 + 2 * static_cast<size_t>(side));
    }
};

// The preconditioner of A (its stencils and diagonal) on these grids.
LinePreconditioner make_line_preconditioner(const NormalMatrix& A, const LocalGrids& g);

// z_c = M^-1 r_c for the channels in `active`, the quads shared among the cores; shared nodes are
// summed over their copies in quad order, so the result does not depend on the thread count.
// `dots` as multiply's, of r and z.
void precondition(const NormalMatrix& A, const SharedNodes& s, const LocalGrids& g,
                  const LinePreconditioner& m, const Planes& r, Planes& z,
                  const std::vector<int>& active, std::vector<float>& products,
                  std::vector<double>* dots = nullptr);

// The solver's vector kernels. The reductions keep four partial sums (k mod 4), so that a loop is
// not bound by the latency of one double accumulator; the order, and so the result, is fixed.
// `owner` counts each sample once. On x86-64 they are built twice, for AVX2 and for the baseline,
// with the same float and double operations in the same order (no fused multiply-add), so that the
// two give the same bits (a test compares them).
struct VectorKernels {
    // o[c] = sum over the nine entries e of st[e][c] g[c + offset[e]], c < n, in entry order.
    void (*stencil_row)(const float* const* st, const float* g, const int32_t* offset, int32_t n,
                        float* o);
    double (*dot)(const float* a, const float* b, const float* owner, size_t n);
    // a . b over the entries whose shared[k] is 0 (a quad's own nodes).
    double (*own_dot)(const float* a, const float* b, const uint8_t* shared, size_t n);
    // One conjugate-gradient step of a channel, in one pass: x += step p, r -= step Ap; returns
    // r.z (z = r / d) and r.r.
    std::pair<double, double> (*step_channel)(float step, float* x, float* r, const float* p,
                                              const float* ap, const float* inverse,
                                              const float* owner, size_t n);
    // The next search direction: p = r / d + beta p.
    void (*next_direction)(float beta, const float* r, const float* inverse, float* p, size_t n);
    // The same step for another preconditioner, which gives z afterwards: returns r.r alone.
    double (*step_residual)(float step, float* x, float* r, const float* p, const float* ap,
                            const float* owner, size_t n);
    // p = z + beta p.
    void (*next_direction_from)(float beta, const float* z, float* p, size_t n);
};

const VectorKernels& baseline_kernels();
// The AVX2 build, or null where the machine has none.
const VectorKernels* avx2_kernels();
// The build the machine runs best, picked once.
const VectorKernels& vector_kernels();

double dot(const std::vector<float>& a, const std::vector<float>& b,
           const std::vector<float>& owner);

}  // namespace tesswave::detail
