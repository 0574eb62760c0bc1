// A morph between two images on two meshes of one topology (DESIGN.md 3): both images are
// sampled on their own mesh at level J and transformed, so coefficient k of A and of B describe
// corresponding material; a frame at time t blends the coefficients band by band on the
// schedule, reconstructs, and renders on the interpolated geometry.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/math/hierarchy.h"
#include "core/math/image.h"
#include "core/math/mesh.h"
#include "core/math/progress.h"
#include "core/math/project.h"
#include "core/math/render.h"
#include "schedule.h"
#include "warp.h"

namespace tesswave::morph {

struct MorphOptions {
    int levels = 0;             // J; 0: chosen for `density`
    double density = 2.0;       // samples per output pixel when J is chosen
    int width = 0, height = 0;  // output size; 0: image A's
    Schedule schedule = {};
    // Carry the detail the mesh cannot hold (each image minus its own resampling) by a pixel
    // warp through the same mesh map, blended like the finest band: no resampling loss. Point
    // sampling only: after the projection the residual warp did not measurably help (the middle
    // frame of tests/morph_pair_test: 44.9 dB with it, 45.0 without) and it costs half a frame.
    bool residual = true;
    // How A and B go on their meshes (project.h). Point sampling with the residual warp by default:
    // on the procedural pair (tests/morph_pair_test) the middle frame is 49.3 dB that way, 45.0 dB
    // with the projection (with or without the residual warp).
    Sampling sampling = Sampling::point;
    Progress progress = {};  // sampling and transforms (the constructor's work)
};

// J of a morph: options.levels, or the level of mesh_a (scaled to the output size) closest to
// options.density samples a pixel. The CLI asks it to name the schedule's levels.
int morph_levels(const Mesh& mesh_a, int width, int height, const MorphOptions& options);

// A morph whose mesh would pass the hierarchy's sample limit, refused (Error naming `name`, the
// image or option that sets the size) before the work: check_sample_estimate before the
// matching, where the estimate (density samples a pixel of the output) cannot fit, since the
// level chosen for a density lands within a factor 2 of it; check_samples with the pair's mesh,
// exactly, before the morph is built. With options.levels (J) given, only the exact count.
void check_sample_estimate(const std::string& name, int width, int height, double density,
                           int levels);
void check_samples(const std::string& name, const Mesh& mesh, int width, int height,
                   const MorphOptions& options);

struct FrameOptions {
    bool preview = false;  // render the coarse levels only (J - 2, at least 1): fast look-ups
};

class Morph {
  public:
    // mesh_a lies on A's pixel rectangle, mesh_b on B's; same vertex count and faces (Error
    // otherwise, or when either is invalid). The images may differ in size and channel count
    // (grey is widened to RGB, alpha dropped unless both have it).
    Morph(const Image& a, const Image& b, const Mesh& mesh_a, const Mesh& mesh_b,
          const MorphOptions& options);

    // The frame at t in [0, 1].
    Image frame(double t, const FrameOptions& options = {}) const;

    // The T0 vertices at t (output pixels), repaired if they fold.
    std::vector<Vec2> geometry(double t) const;

    // Image A (side 0) or B (side 1) alone on the geometry at t: the warped endpoint that
    // measures of ghosting compare the frame at t with.
    Image warped(double t, int side) const;

    // For tests and reports: the samples of A and B on their meshes (level J), the coefficients
    // blended at t before reconstruction, and the energy (sum of squares over channels) of each
    // detail level of those coefficients (index j: the details of step j).
    // With the aware schedule, `correspondence(i)` is detail coefficient i's local correlation
    // between A and B in [0, 1] (0 for the base).
    double correspondence(int32_t i) const;
    const std::vector<std::vector<float>>& samples_a() const { return samples_a_; }
    const std::vector<std::vector<float>>& samples_b() const { return samples_b_; }
    std::vector<std::vector<float>> blended(double t) const;
    std::vector<double> detail_energy(double t) const;

    int levels() const { return hierarchy_.finest(); }
    int64_t samples() const { return hierarchy_.num_samples(hierarchy_.finest()); }
    int width() const { return width_; }
    int height() const { return height_; }

  private:
    // The frame rendered from `planes` (the reconstructed samples) plus the residuals at t (side
    // -1: blended by the schedule; 0 or 1: that image's alone).
    Image with_residuals(const RenderPlan& plan, std::vector<std::span<const float>> planes,
                         double t, int side) const;
    Image render_at(std::vector<std::vector<float>> coefficients, double t, bool preview,
                    int side) const;
    void measure_agreement();

    MorphOptions options_;
    int width_ = 0, height_ = 0;
    Mesh topology_;                  // mesh_a's faces on the output domain
    std::vector<Vec2> va_, vb_;      // T0 vertices of A and B in output pixels
    Hierarchy hierarchy_, preview_;  // levels J and the preview level
    std::vector<std::vector<float>> samples_a_, samples_b_, coeff_a_, coeff_b_;
    std::vector<std::vector<double>> energy_a_, energy_b_;  // [channel][detail level]
    Image residual_a_, residual_b_;                         // each image minus its resampling
    std::vector<QuadMap> quads_a_, quads_b_;                // in A's pixels and in B's
    // aware: per detail coefficient, the local energies of A's and B's detail and their inner
    // product (over channels, smoothed over the coefficient's neighbourhood on its level).
    std::vector<float> local_a_, local_b_, local_ab_;
    std::vector<float> corresponding_;  // how far each counts as corresponding, 0..1
    // aware, per T_J sample: plane 0, how far its detail counts as corresponding by the pixels
    // (corresponding() of the mean of detail_agreement in A's pixels, B warped to A, and in B's,
    // A warped to B, at its places); with the residual warp, planes 1 to 3 the residuals' local
    // energies and inner product at its place in A (B's residual warped to A, 7x7 windows),
    // which the residual band's weights need.
    std::vector<std::vector<float>> placed_;
};

}  // namespace tesswave::morph
