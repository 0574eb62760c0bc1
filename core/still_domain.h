// The transform side of the still codec (internal to still_codec.cpp and the video codec): from
// an image to the coefficients one .twi header describes and back. Mesh path: sample the image on
// T_J (or read the pixels directly when the vertices sit on pixel centres), colour transform,
// lifting; fixed-grid path: colour transform and the 5/3 or 9/7 on the pixels.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "coding_layout.h"
#include "hierarchy.h"
#include "image.h"
#include "render.h"
#include "twi_format.h"

namespace tesswave {

class StillDomain {
  public:
    // probes > 0: compute the band norms (encoder); 0: take them from the header (decoder).
    StillDomain(const TwiHeader& header, int probes);

    const CodingLayout& layout() const { return layout_; }
    int32_t size() const { return layout_.size; }

    // Lossy: coefficients of the image in the header's colour space.
    std::vector<std::vector<float>> analyze(const Image& image) const;
    Image synthesize(std::vector<std::vector<float>> coefficients) const;
    // Lossless: integer samples (pixel values in [0, 2^depth - 1]), integer lifting.
    std::vector<std::vector<int32_t>> analyze_int(const Image& image) const;
    Image synthesize_int(std::vector<std::vector<int32_t>> coefficients) const;
    // Inverse lifting and colour transform only: the integer samples.
    std::vector<std::vector<int32_t>> inverse_int(std::vector<std::vector<int32_t>> x) const;
    // The integer samples before colour transform and lifting (mesh samples or pixels).
    std::vector<std::vector<int32_t>> samples_int(const Image& image) const;

  private:
    std::vector<std::vector<float>> samples(const Image& image) const;
    Image to_image(const std::vector<std::vector<float>>& samples) const;

    const TwiHeader& header_;
    std::optional<Hierarchy> hierarchy_;    // mesh path
    std::vector<int32_t> pixel_of_sample_;  // centres placement: the pixel each sample reads
    std::vector<int32_t> written_samples_;  // the samples that are pixels (one per pixel)
    std::optional<RenderPlan> plan_;        // area placement
    CodingLayout layout_;
};

}  // namespace tesswave
