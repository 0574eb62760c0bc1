// The paper's experiment (its Figure 7) on any image, beside fixed-grid wavelets: put the image
// on a tessellation at level J, transform, keep k % of the detail coefficients, reconstruct and
// render; do the same with the fixed-grid 5/3 and 9/7 on the original pixels; measure all of it
// against the original.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "core/math/image.h"
#include "core/math/mesh.h"
#include "core/math/progress.h"
#include "core/math/project.h"
#include "core/math/selection.h"

namespace tesswave {

struct AnalysisOptions {
    int levels = 7;                                     // J
    std::vector<double> keep = {10, 1, 0.1};            // percentages of the detail coefficients
    SelectionRule picture_rule = SelectionRule::paper;  // the rule of the reconstructions kept
    int grid_levels = 5;                                // fixed-grid decomposition levels
    Sampling sampling = Sampling::fit;                  // how the image is put on the mesh
    ProjectOptions projection = {};                     // for Sampling::fit
    Progress progress = {};                             // optional
};

struct AnalysisRow {
    // "resample point", "resample fit" (both whatever the sampling), "mesh paper", "mesh l2", "grid
    // 5/3", "grid 9/7", and "grid 5/3 =n", "grid 9/7 =n": the fixed grid keeping as many
    // coefficients as the mesh rows of that keep.
    std::string method;
    double keep_percent = 100;
    int64_t kept = 0;   // detail coefficients kept
    int64_t total = 0;  // detail coefficients in all
    double psnr = 0, ssim = 0;
};

struct AnalysisResult {
    int levels = 0;
    int64_t samples = 0;
    double samples_per_pixel = 0;
    Image resampled;                // put on the mesh by the chosen sampling and rendered back
    int projection_iterations = 0;  // Sampling::fit
    Image coefficients;  // the transform rendered: coarse values as they are, details x10 + 1/2
    std::vector<Image> mesh_images;                   // per keep value, picture_rule
    std::vector<Image> grid53_images, grid97_images;  // per keep value, paper rule
    std::vector<AnalysisRow> rows;
};

// The mesh domain must be the image's pixel rectangle (Error otherwise).
AnalysisResult analyze_image(const Image& image, const Mesh& mesh, const AnalysisOptions& options);

}  // namespace tesswave
