// The coding domain of the still (.twi) and video (.twv) codecs: from an image to the coefficients
// the bit-plane coder codes, and back. Mesh path: sample the image on T_J at given T0 vertex
// positions (or read the pixels directly when the vertices sit on pixel centres), colour
// transform, lifting (or the 9/7 on the lattice of a grid mesh's samples); fixed-grid path: colour
// transform and the 5/3 or 9/7 on the pixels.
//
// The topology (hierarchy and coding layout) is built once; positions are per call, so a video
// group codes every frame of a moving mesh with one domain. The quantizer step of band b in
// channel c for a base step s is s * channel_factor[c] / norm[b] (DESIGN.md 2.6): the one
// band-step formula of both codecs.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "core/codec/coding_layout.h"
#include "core/codec/twi_format.h"
#include "core/math/fixed_grid.h"
#include "core/math/hierarchy.h"
#include "core/math/image.h"
#include "core/math/project.h"
#include "core/math/render.h"

namespace tesswave {

using Planes = std::vector<std::vector<float>>;
using IntPlanes = std::vector<std::vector<int32_t>>;

// Read-only spans of each plane, as the bit-plane coder takes them.
template <class T>
std::vector<std::span<const T>> const_spans(const std::vector<std::vector<T>>& planes) {
    return {planes.begin(), planes.end()};
}

// The one mapping from a transform choice to its fixed-grid wavelet (the 5/3 for the mesh too:
// its coarse-to-fine rules are the 5/3's on a grid).
GridWavelet wavelet_of(TwiTransform transform);

// What a domain is built from.
struct DomainShape {
    TwiTransform transform = TwiTransform::mesh;
    int width = 0, height = 0, channels = 1;        // of the images
    SampleFormat format = SampleFormat::u8;         // of synthesized images
    TwiColour colour = TwiColour::none;             // applied to the first three channels
    int levels = 0;                                 // J (mesh) or decomposition levels (grid)
    Mesh mesh = {};                                 // mesh path: T0 at rest
    MeshPlacement placement = MeshPlacement::area;  // see TwiHeader
    std::vector<float> channel_factors = {};        // step factor per channel
    // Mesh path: the mesh's domain is a canvas in the image's pixel units of which each image is
    // a window (a video group whose camera pans): the vertex positions analyze and synthesize
    // take are in the image's pixel coordinates, the window's offset taken off, and reach past
    // the image; there is no rest plan, so positions must be given.
    bool canvas = false;
    // Mesh path: the transform of the samples. lattice97 needs a grid: T0 has grid_mesh's faces
    // for grid_cols x grid_rows cells (its vertices may sit anywhere).
    MeshWavelet mesh_wavelet = MeshWavelet::lifted;
    int grid_cols = 0, grid_rows = 0;

    bool operator==(const DomainShape&) const = default;
};

// The shape a .twi header describes.
DomainShape still_shape(const TwiHeader& header);

// What an encoder's band norms measure: the samples' basis functions (in pixel units), or the
// image they render to, where the renderer's bilinear interpolation damps fine detail
// (weigh_norms_by_rendering; mesh samples placed by area, not on a canvas, only: elsewhere the
// same as samples).
enum class BandNorms : uint8_t { samples, rendered };

class CodingDomain {
  public:
    // Band norms: measured with `probes` impulses per band (encoders) as `weigh` says, or, with
    // probes == 0, taken from `norms` (decoders; its size must match the layout's bands).
    CodingDomain(DomainShape shape, int probes, std::span<const float> norms = {},
                 BandNorms weigh = BandNorms::samples);

    const DomainShape& shape() const { return shape_; }
    const CodingLayout& layout() const { return layout_; }
    bool is_mesh() const { return hierarchy_.has_value(); }
    const Hierarchy* hierarchy() const { return hierarchy_ ? &*hierarchy_ : nullptr; }
    int32_t size() const { return layout_.size; }

    // Quantizer step of a band in a channel for a base step, and the steps of every band.
    float step(int channel, int band, float base_step) const;
    std::vector<float> band_steps(int channel, float base_step) const;
    // Planes of the domain's shape, all zero.
    Planes zeros() const;

    // Lossy: coefficients of `image` put on the mesh at T0 vertex positions `vertices` (mesh
    // path; empty: the rest mesh; ignored on the fixed grid) by `sampling` (ignored where the
    // samples are pixels). `out` is resized as needed.
    void analyze(const Image& image, std::span<const Vec2> vertices, Planes& out,
                 Sampling sampling = Sampling::point, const ProjectOptions& projection = {}) const;
    Planes analyze(const Image& image, Sampling sampling = Sampling::point,
                   const ProjectOptions& projection = {}) const;
    // analyze() in two steps: the samples of `image` (mesh samples, or pixels), then in place
    // their coefficients; a caller may change the samples between the two.
    void sample(const Image& image, std::span<const Vec2> vertices, Planes& out,
                Sampling sampling = Sampling::point, const ProjectOptions& projection = {}) const {
        sample_into(image, vertices, out, sampling, projection);
    }
    void analyze_samples(Planes& samples) const { transform(samples); }
    // Coefficients of `image` at rest, projected for each of `smoothness` in turn
    // (project_image_each: one assembly, each solve starting from the one before), handed to
    // `take`, which may consume them. Where samples are pixels, the pixels for each.
    void analyze_fits(const Image& image, std::span<const double> smoothness,
                      const ProjectOptions& projection,
                      const std::function<void(size_t, Planes&)>& take) const;
    // The image of `coefficients` (consumed) on those vertex positions; `plan`, when given, is
    // plan_for(vertices), kept by a caller that renders the same positions many times.
    void synthesize(Planes coefficients, std::span<const Vec2> vertices, Image& out,
                    const RenderPlan* plan = nullptr) const;
    // The render plan synthesize makes for these positions (a moved mesh, a canvas); none where
    // it needs none (at rest its own, or samples that are pixels).
    std::optional<RenderPlan> plan_for(std::span<const Vec2> vertices) const;
    Image synthesize(Planes coefficients) const;

    // Lossless, at rest: integer samples (pixel values in [0, 2^depth - 1]), integer lifting.
    IntPlanes analyze_int(const Image& image) const;
    Image synthesize_int(IntPlanes coefficients) const;
    // Inverse lifting and colour transform only: the integer samples.
    IntPlanes inverse_int(IntPlanes x) const;
    // The integer samples before colour transform and lifting (mesh samples or pixels).
    IntPlanes samples_int(const Image& image) const;

  private:
    void check_image(const Image& image) const;
    // Encoders, area placement at rest: the band norms of the image `plan` renders (the renderer
    // damps fine detail), not of the samples.
    void weigh_norms_by_rendering(const RenderPlan& plan);
    bool at_rest(std::span<const Vec2> vertices) const;  // the rest positions, as rest_plan_'s
    bool rest_plan_is_pixels() const;
    void transform(Planes& samples) const;  // colour transform and analysis
    void synthesis(Planes& x) const;        // the inverse transform of any number of planes
    void inverse(Planes& x) const;          // synthesis and inverse colour transform
    void lattice_transform(Planes& x, bool forward) const;
    void sample_into(const Image& image, std::span<const Vec2> vertices, Planes& out,
                     Sampling sampling = Sampling::point,
                     const ProjectOptions& projection = {}) const;
    void to_image(const Planes& samples, std::span<const Vec2> vertices, Image& out,
                  const RenderPlan* plan = nullptr) const;
    GridTransformOptions grid_options() const;

    DomainShape shape_;
    std::optional<Hierarchy> hierarchy_;    // mesh path
    std::vector<int32_t> pixel_of_sample_;  // centres placement: the pixel each sample reads
    std::vector<int32_t> written_samples_;  // the samples that are pixels (one per pixel)
    std::optional<RenderPlan> rest_plan_;   // area placement: rendering at rest
    // Lattice 9/7: each T_J sample's place in the lattice, and the lattice's size.
    std::vector<int32_t> lattice_;
    int lattice_width_ = 0, lattice_height_ = 0;
    CodingLayout layout_;
};

// The domain CodingDomain(shape, probes, norms, weigh) builds, from a small process-wide cache:
// the last few domains are kept, so that coding with one mesh and size again (compare's rates,
// the groups of a video, a benchmark) reuses the hierarchy, coding layout and render plan instead
// of building them anew (for a mesh they are most of a decode). Entries are equal when all four
// are. Thread-safe; a domain is read-only, so one entry may serve many threads.
std::shared_ptr<const CodingDomain> shared_domain(const DomainShape& shape, int probes,
                                                  std::span<const float> norms = {},
                                                  BandNorms weigh = BandNorms::samples);

// Empties that cache (its memory is freed once no caller holds a domain).
void clear_domain_cache();

}  // namespace tesswave
