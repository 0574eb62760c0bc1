// Keeping the k % largest detail coefficients (DESIGN.md 2.6). The paper's rule ranks a
// coefficient by its Euclidean length over the colour channels; the L2 rule multiplies that by
// the L2 norm of the coefficient's basis function (per band: level and point type), which ranks
// coefficients by how much image energy dropping them costs. The base level is always kept.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "core/math/hierarchy.h"

namespace tesswave {

enum class SelectionRule { paper, l2 };

// A band: the detail coefficients [begin, end) of one point type at one decomposition step.
struct Band {
    int level = 0;  // the step T_{level+1} -> T_level
    char type = 'e';
    int32_t begin = 0, end = 0;
    double norm = 1.0;  // L2 norm of a basis function of the band, in the image domain
};

// The L2 norm in the image of the basis functions of coefficients [begin, end): the mean over
// `probes` unit impulses spread through the range, reconstructed to T_J, each sample standing for
// domain_area / |V_J| pixels. 1 when probes is 0. `scratch` is reused between calls.
double impulse_norm(const Hierarchy& hierarchy, int32_t begin, int32_t end, double domain_area,
                    int probes, std::vector<double>& scratch);

// The bands of a hierarchy's finest level, finest last; norms from the reconstruction of unit
// impulses (up to `probes` per band, averaged) integrated over the domain area.
std::vector<Band> mesh_bands(const Hierarchy& hierarchy, double domain_area, int probes = 8);

// Zeroes every detail coefficient in [first_detail, size) except the `count` with the largest
// weighted Euclidean length (weights per coefficient, or none for the paper's rule). Ties are
// broken by index, so exactly `count` survive. Returns the number kept.
int64_t keep_largest(std::span<const std::span<float>> planes, int32_t first_detail, int64_t count,
                     std::span<const float> weights = {});

// The same over an explicit list of detail coefficient indices (fixed-grid layouts, where the
// base band is not a prefix); weights are indexed like the planes.
int64_t keep_largest(std::span<const std::span<float>> planes, std::span<const int32_t> details,
                     int64_t count, std::span<const float> weights = {});

// Per-coefficient weights from bands (1 for coefficients outside every band).
std::vector<float> band_weights(const std::vector<Band>& bands, int32_t size);

// The number of detail coefficients k % of `details` means (rounded to nearest).
int64_t keep_count(int64_t details, double percent);

}  // namespace tesswave
