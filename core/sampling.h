// Sampling an image at mesh vertex positions (DESIGN.md 2.5): bilinear in the pixel grid, with
// pixel (i,j)'s value at its centre (i+1/2, j+1/2) and edges clamped.
#pragma once

#include <span>
#include <vector>

#include "geometry.h"
#include "image.h"

namespace tesswave {

// One plane per image channel, one value per position.
std::vector<std::vector<float>> sample_bilinear(const Image& image,
                                                std::span<const Vec2> positions);

}  // namespace tesswave
